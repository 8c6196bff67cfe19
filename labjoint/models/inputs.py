"""What a joint model is evaluated on: a displacement record with its derivatives.

Velocity and acceleration (the stated, noise-robust method): spectral differentiation of
the zero-phase low-passed record. The record is multiplied in the frequency domain by
i omega (velocity) or -omega^2 (acceleration) and by |H|^2 of a 5th-order Butterworth
low-pass at ``band_hz`` (the response of a forward-backward filter, i.e. zero phase, as
seed 002's 3 kHz filter). Default band: max(3 kHz, 8 x excitation frequency), capped at
0.4 fs. Within the band the derivative is exact (error < 1e-4 below band/2); above it
noise is suppressed. Edges: the record is continued periodically by two or more of its
first/last periods (cubic interpolation at the fractional period), then a cubic matching
the end values and end curvatures is removed and the rest is extended oddly, so the
FFT sees a smooth periodic signal and no wrap-around jump.

Warm-up: every hysteretic state starts relaxed (zero hysteretic force, no slip) at the
first sample of the history. Pass whole records from their start and compare on the
steady samples. For records that start mid-steady-state (CSV files from other
generators), ``prime_cycles`` prepends that many copies of the first steady cycle
(its periodic continuation backwards in time), so the state is steady when the record
begins; model outputs always cover the record samples only.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize_scalar
from scipy.signal import savgol_filter

from labjoint.errors import InputError

DEFAULT_BAND_HZ = 3000.0
BUTTER_ORDER = 5
EDGE_WINDOW = 9   # samples of the local quartic giving end curvatures
PAD_SAMPLES = 128  # at least this many samples of periodic continuation each side


def _as_1d(x: Any, field_name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim != 1:
        raise InputError(f"expected a 1-D array, got shape {a.shape}", field=field_name)
    if a.size and not np.all(np.isfinite(a)):
        raise InputError(f"contains non-finite values at sample {int(np.argmin(np.isfinite(a)))}",
                         field=field_name)
    return a


def default_band(fs: float, frequency_hz: float | None = None, band_hz: float | None = None) -> float:
    """Derivative band (Hz): ``band_hz`` or max(3 kHz, 8 f), capped at 0.4 fs."""
    if band_hz is not None:
        if not (np.isfinite(band_hz) and band_hz > 0):
            raise InputError(f"band must be > 0 Hz, got {band_hz}", field="band_hz")
        return float(min(band_hz, 0.4 * fs))
    band = DEFAULT_BAND_HZ if frequency_hz is None else max(DEFAULT_BAND_HZ, 8.0 * frequency_hz)
    return float(min(band, 0.4 * fs))


def _periodic(x: np.ndarray, per: float, pos: np.ndarray, start: int) -> np.ndarray:
    """x at sample positions ``pos`` folded by period ``per`` into [start, start + per)."""
    k = int(np.ceil(per)) + 4
    idx = np.arange(start, start + k, dtype=float)
    return CubicSpline(idx, x[start:start + k])(start + np.mod(pos - start, per))


def _spectral(u: np.ndarray, fs: float, band: float, order: int = BUTTER_ORDER
              ) -> tuple[np.ndarray, np.ndarray]:
    """Band-limited derivatives with cubic end matching and odd extension (no wrap jump)."""
    n = u.size
    tau = np.arange(n) / fs
    T = tau[-1]
    curv = savgol_filter(u, EDGE_WINDOW, 4, deriv=2, delta=1.0 / fs, mode="interp")
    c2 = curv[0] / 2.0
    c3 = (curv[-1] - curv[0]) / (6.0 * T)
    c1 = (u[-1] - u[0] - c2 * T * T - c3 * T ** 3) / T
    d = u - (u[0] + c1 * tau + c2 * tau ** 2 + c3 * tau ** 3)
    ext = np.concatenate([d, -d[-2:0:-1]])
    m = ext.size
    spec = np.fft.rfft(ext)
    f = np.fft.rfftfreq(m, 1.0 / fs)
    jw = 2j * np.pi * f / (1.0 + (f / band) ** (2 * order))
    v = np.fft.irfft(spec * jw, m)[:n] + c1 + 2 * c2 * tau + 3 * c3 * tau ** 2
    a = np.fft.irfft(spec * jw * (2j * np.pi * f), m)[:n] + 2 * c2 + 6 * c3 * tau
    return v, a


def derivatives(u: np.ndarray, fs: float, band_hz: float | None = None,
                frequency_hz: float | None = None, periodic: bool = True,
                order: int = BUTTER_ORDER) -> tuple[np.ndarray, np.ndarray]:
    """Velocity (m/s) and acceleration (m/s^2) of ``u`` (module docstring: the method).

    ``periodic=False``: a record that does not repeat (random, transient) is not continued
    periodically at its edges; only the cubic end matching and odd extension are used.
    ``order``: of the Butterworth-shaped roll-off at the band (a steeper one keeps a
    record's derivatives to its excited band, :mod:`labjoint.compare.kinds.record`).
    """
    u = np.asarray(u, dtype=float)
    if u.size < 2 * EDGE_WINDOW:
        raise InputError(f"record has {u.size} samples, need at least {2 * EDGE_WINDOW}",
                         field="displacement")
    if not periodic:
        return _spectral(u, fs, default_band(fs, frequency_hz, band_hz), order)
    f = frequency_hz
    if f is None:
        try:
            f = estimate_frequency(u, fs)
        except InputError:
            f = None
    band = default_band(fs, f, band_hz)
    per = fs / f if f else np.inf
    if not np.isfinite(per) or per < 4 or u.size < 2 * per + 8:
        return _spectral(u, fs, band, order)
    n_pad = int(round(np.ceil(max(PAD_SAMPLES, per) / per) * per))
    pre = _periodic(u, per, np.arange(-n_pad, 0, dtype=float), 0)
    post = _periodic(u, per, np.arange(u.size, u.size + n_pad, dtype=float),
                     u.size - int(np.ceil(per)) - 4)
    v, a = _spectral(np.concatenate([pre, u, post]), fs, band, order)
    return v[n_pad:n_pad + u.size], a[n_pad:n_pad + u.size]


def shift(x: np.ndarray, samples: float) -> np.ndarray:
    """x delayed by a (fractional) number of samples: y[i] = x(i - samples), 4-point cubic
    Lagrange interpolation (exact for cubics; error ~(omega dt)^4 / 100 for a tone),
    end samples held beyond the record."""
    n = x.size
    base = np.floor(-samples)
    mu = -samples - base
    idx = np.arange(n) + int(base)
    w = (-mu * (mu - 1) * (mu - 2) / 6, (mu + 1) * (mu - 1) * (mu - 2) / 2,
         -(mu + 1) * mu * (mu - 2) / 2, (mu + 1) * mu * (mu - 1) / 6)
    out = np.zeros(n)
    for k, wk in zip((-1, 0, 1, 2), w):
        if wk != 0.0:
            out += wk * x[np.clip(idx + k, 0, n - 1)]
    return out


def estimate_frequency(u: np.ndarray, fs: float) -> float:
    """Fundamental frequency (Hz) of ``u``: Hann-windowed FFT peak, refined by maximising
    the windowed DTFT magnitude within +-1 bin (exact for a pure tone up to leakage)."""
    x = np.asarray(u, float) - np.mean(u)
    if x.size < 8 or not np.any(x):
        raise InputError("cannot estimate the frequency of a constant or too short record",
                         field="frequency_hz")
    xw = x * np.hanning(x.size)
    spec = np.abs(np.fft.rfft(xw))
    k = int(np.argmax(spec[1:])) + 1
    n = np.arange(x.size)

    def neg_mag(kk: float) -> float:
        return -abs(np.dot(xw, np.exp(-2j * np.pi * kk * n / x.size)))

    res = minimize_scalar(neg_mag, bounds=(max(k - 1.0, 0.5), k + 1.0), method="bounded",
                          options={"xatol": 1e-6})
    return float(res.x * fs / x.size)


@dataclass(frozen=True, eq=False)
class ModelInputs:
    """Displacement history a model is evaluated on (SI units).

    ``u_hist``, ``v_hist``, ``a_hist`` hold the full history: ``n_prime`` priming samples
    followed by the record. ``u``, ``v``, ``a``, ``t`` are the record part. Build with
    :meth:`from_record`; input effects (backlash, channel_delay) derive transformed
    copies with :meth:`with_history`.
    """

    u_hist: np.ndarray
    v_hist: np.ndarray
    a_hist: np.ndarray
    fs: float
    n_prime: int = 0
    t0: float = 0.0
    frequency_hz: float | None = None
    name: str = ""
    metadata: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def from_record(cls, u: Any, fs: float | None = None, *, t: Any = None,
                    frequency_hz: float | None = None, name: str = "",
                    band_hz: float | None = None, prime_cycles: int = 0, steady_start: int = 0,
                    metadata: Mapping[str, Any] | None = None) -> ModelInputs:
        """Inputs from a displacement record ``u`` (m) sampled at ``fs`` (Hz) or times ``t`` (s).

        ``prime_cycles`` > 0 prepends that many periods of the first steady cycle
        (starting at ``steady_start``); needs ``frequency_hz`` (estimated if omitted).
        """
        u = _as_1d(u, "displacement")
        t0 = 0.0
        if t is not None:
            t = _as_1d(t, "time")
            if t.size != u.size:
                raise InputError(f"time has {t.size} samples, displacement {u.size}", field="time")
            dt = np.diff(t)
            if dt.size == 0 or np.any(dt <= 0):
                raise InputError("time must increase strictly", field="time")
            fs_t = 1.0 / float(np.median(dt))
            if np.max(np.abs(dt * fs_t - 1.0)) > 0.01:
                raise InputError("sampling is not uniform (spacing varies by more than 1 %)", field="time")
            fs = fs_t if fs is None else fs
            t0 = float(t[0])
        if fs is None or not np.isfinite(fs) or fs <= 0:
            raise InputError(f"sample rate must be > 0, got {fs}", field="sample_rate_hz")
        fs = float(fs)
        if frequency_hz is not None and not (np.isfinite(frequency_hz) and 0 < frequency_hz < fs / 2):
            raise InputError(f"frequency must be in (0, fs/2), got {frequency_hz}", field="frequency_hz")
        v, a = derivatives(u, fs, band_hz, frequency_hz)
        md = dict(metadata or {})
        if prime_cycles < 0:
            raise InputError("prime_cycles must be >= 0", field="prime_cycles")
        if prime_cycles == 0:
            return cls(u, v, a, fs, 0, t0, frequency_hz, name, md)
        f = frequency_hz if frequency_hz is not None else estimate_frequency(u[steady_start:], fs)
        pu, pv, pa = _prime(u, v, a, fs, f, int(prime_cycles), int(steady_start))
        return cls(np.concatenate([pu, u]), np.concatenate([pv, v]), np.concatenate([pa, a]),
                   fs, pu.size, t0, frequency_hz if frequency_hz is not None else f, name, md)

    def __len__(self) -> int:
        return self.u_hist.size - self.n_prime

    @property
    def u(self) -> np.ndarray:
        return self.u_hist[self.n_prime:]

    @property
    def v(self) -> np.ndarray:
        return self.v_hist[self.n_prime:]

    @property
    def a(self) -> np.ndarray:
        return self.a_hist[self.n_prime:]

    @property
    def t(self) -> np.ndarray:
        return self.t0 + np.arange(len(self)) / self.fs

    def with_history(self, u_hist: np.ndarray, v_hist: np.ndarray, a_hist: np.ndarray) -> ModelInputs:
        """Same record metadata, transformed history arrays (same length)."""
        return ModelInputs(u_hist, v_hist, a_hist, self.fs, self.n_prime, self.t0,
                           self.frequency_hz, self.name, self.metadata)


def _prime(u: np.ndarray, v: np.ndarray, a: np.ndarray, fs: float, f: float, cycles: int,
           s0: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Periodic backward continuation of the cycle starting at sample s0, ``cycles`` periods."""
    per = fs / f  # samples per period (fractional)
    n_seg = int(np.ceil(per)) + 4
    if s0 < 0 or s0 + n_seg > u.size:
        raise InputError(f"priming needs one full steady cycle ({n_seg} samples) from sample {s0}",
                         field="steady")
    m = int(round(cycles * per))
    idx = np.arange(s0, s0 + n_seg, dtype=float)
    # sample positions -m..-1 mapped into [s0, s0 + per) by the period
    pos = np.arange(-m, 0, dtype=float)
    pos = s0 + np.mod(pos - s0, per)
    out = []
    for x in (u, v, a):
        out.append(CubicSpline(idx, x[s0:s0 + n_seg])(pos))
    return out[0], out[1], out[2]


def _steady_mask(steady: Any, n: int) -> np.ndarray:
    """Bool mask from None (all), a bool mask, a slice, (start, stop) or an index array."""
    if steady is None:
        return np.ones(n, bool)
    if isinstance(steady, slice):
        m = np.zeros(n, bool)
        m[steady] = True
        return m
    if isinstance(steady, tuple) and len(steady) == 2:
        m = np.zeros(n, bool)
        m[int(steady[0]):int(steady[1])] = True
        return m
    arr = np.asarray(steady)
    if arr.dtype == bool:
        if arr.shape != (n,):
            raise InputError(f"steady mask has shape {arr.shape}, record has {n} samples", field="steady")
        return arr.copy()
    if np.issubdtype(arr.dtype, np.integer):
        if arr.size and (arr.min() < -n or arr.max() >= n):
            raise InputError("steady index out of range", field="steady")
        m = np.zeros(n, bool)
        m[arr] = True
        return m
    raise InputError("steady must be a bool mask, slice, (start, stop) or index array", field="steady")


@dataclass(frozen=True, eq=False)
class RunData:
    """One run for fitting: model inputs, measured joint force (N) and its steady samples."""

    inputs: ModelInputs
    force: np.ndarray
    steady: np.ndarray
    _frequency: float = field(init=False, repr=False, default=0.0)

    def __post_init__(self) -> None:
        f = _as_1d(self.force, "force")
        if f.size != len(self.inputs):
            raise InputError(f"force has {f.size} samples, displacement {len(self.inputs)}",
                             field="force")
        m = _steady_mask(self.steady, f.size)
        if not m.any():
            raise InputError(f"run '{self.inputs.name}' has no steady samples", field="steady")
        object.__setattr__(self, "force", f)
        object.__setattr__(self, "steady", m)
        freq = self.inputs.frequency_hz
        if freq is None:
            freq = estimate_frequency(self.inputs.u[m], self.inputs.fs)
        object.__setattr__(self, "_frequency", float(freq))

    @property
    def name(self) -> str:
        return self.inputs.name

    def renamed(self, name: str, steady: Any = None) -> RunData:
        """The same data under another name (and, if given, other judged samples)."""
        return RunData(replace(self.inputs, name=name), self.force,
                       self.steady if steady is None else steady)

    @property
    def frequency_hz(self) -> float:
        """Excitation frequency (Hz): from the inputs, else estimated from the steady u."""
        return self._frequency

    @classmethod
    def from_arrays(cls, u: Any, force: Any, fs: float | None = None, *, t: Any = None,
                    steady: Any = None, frequency_hz: float | None = None, name: str = "",
                    band_hz: float | None = None, prime_cycles: int = 0,
                    metadata: Mapping[str, Any] | None = None) -> RunData:
        """Run data from arrays; ``steady`` is a bool mask, slice, (start, stop) or indices."""
        u = _as_1d(u, "displacement")
        mask = _steady_mask(steady, u.size)
        s0 = int(np.argmax(mask)) if mask.any() else 0
        inp = ModelInputs.from_record(u, fs, t=t, frequency_hz=frequency_hz, name=name,
                                      band_hz=band_hz, prime_cycles=prime_cycles, steady_start=s0,
                                      metadata=metadata)
        return cls(inp, _as_1d(force, "force"), mask)

    @classmethod
    def from_run(cls, run: Any, *, steady: Any = None, band_hz: float | None = None,
                 prime_cycles: int = 0) -> RunData:
        """Run data from a :class:`labjoint.storage.run.Run` (SI arrays + metadata)."""
        return cls.from_arrays(run.displacement, run.force, run.sample_rate_hz, steady=steady,
                               frequency_hz=run.frequency_hz, name=run.name, band_hz=band_hz,
                               prime_cycles=prime_cycles, metadata=dict(run.metadata))
