"""Broadband excitation for the generator's arbitrary-waveform memory: one period of points.

A waveform of ``N`` points (2..8,192 on the AFG1022) played ``f_rep`` times per second has
period ``T = 1 / f_rep`` and can only hold the lines ``k f_rep`` (k = 1 .. N/2 - 1). The
generator holds each point for ``1 / (N f_rep)`` (a staircase), so the points must be
denser than the band needs: the highest line is kept at or below ``N f_rep / (2 os)``
with ``os`` (the oversampling, default 4) so that the staircase's images start at
``(2 os - 1)`` times the band's top and its droop there is under 3 %. Hence at resolution
``df = f_rep`` a multisine has at most :func:`max_lines` ``= N / (2 os) - 1`` lines:
1,023 with 8,192 points and os = 4.

Every waveform is normalised to a peak of 1: the generator's amplitude setting
(Vpp = 2 x peak) is then the waveform's peak voltage, whatever its shape.

>>> w = multisine(f_min_hz=10, f_max_hz=50, resolution_hz=1, seed=1)
>>> len(w.lines_hz), w.period_s, round(float(np.max(np.abs(w.points))), 12)
(41, 1.0, 1.0)
>>> max_lines(8192)
1023
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from labjoint.errors import InputError

MAX_POINTS = 8192
MIN_POINTS = 2
OVERSAMPLING = 4
#: Periods and frequencies a waveform may have (the AFG1022 plays up to 25 MHz; a period
#: longer than a day is not an excitation).
PERIOD_RANGE_S = (1e-6, 86400.0)
MIN_FREQUENCY_HZ, MAX_FREQUENCY_HZ = 1e-6, 25e6


@dataclass(frozen=True)
class Waveform:
    """One period of a peak-normalised waveform and what it excites."""

    kind: str                      # "multisine" | "swept_sine" | "random"
    points: np.ndarray = field(repr=False, compare=False)
    period_s: float
    band_hz: tuple[float, float]
    lines_hz: tuple[float, ...] = ()
    crest_factor: float = math.nan
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def frequency_hz(self) -> float:
        """Repetition frequency 1 / period (what the generator's frequency is set to)."""
        return 1.0 / self.period_s

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (stored in each run's metadata as ``excitation``)."""
        return {"kind": self.kind, "period_s": self.period_s, "band_hz": list(self.band_hz),
                "n_lines": len(self.lines_hz), "lines_hz": list(self.lines_hz[:64]),
                "n_points": int(self.points.size), "crest_factor": self.crest_factor,
                "source": "generator_arbitrary_waveform", **self.info}


def max_lines(n_points: int = MAX_POINTS, oversampling: float = OVERSAMPLING) -> int:
    """Most lines (at one resolution) a waveform of ``n_points`` can hold (module doc)."""
    return int(n_points // (2 * oversampling)) - 1


def _check_period(period_s: float, name: str = "period_s") -> float:
    p = float(period_s)
    if not (math.isfinite(p) and PERIOD_RANGE_S[0] <= p <= PERIOD_RANGE_S[1]):
        raise InputError(f"a waveform's period must be within {PERIOD_RANGE_S[0]:g}.."
                         f"{PERIOD_RANGE_S[1]:g} s, got {period_s!r}", field=name)
    return p


def _check_frequency(f: float, name: str) -> float:
    x = float(f)
    if not (math.isfinite(x) and MIN_FREQUENCY_HZ <= x <= MAX_FREQUENCY_HZ):
        raise InputError(f"must be within {MIN_FREQUENCY_HZ:g}..{MAX_FREQUENCY_HZ:g} Hz, got {f!r}",
                         field=name)
    return x


def _points_for(f_max_hz: float, period_s: float, n_points: int | None,
                oversampling: float, field: str = "f_max_hz") -> int:
    """Points per period: ``n_points`` checked, or the most the memory holds."""
    n = MAX_POINTS if n_points is None else int(n_points)
    if not MIN_POINTS <= n <= MAX_POINTS:
        raise InputError(f"a waveform has {MIN_POINTS}..{MAX_POINTS} points, got {n_points!r}",
                         field="n_points")
    top = n / period_s / (2 * oversampling)
    if f_max_hz > top * (1 + 1e-9):
        raise InputError(f"{f_max_hz:g} Hz is above what {n} points per {period_s:g} s period "
                         f"play cleanly ({top:g} Hz = points / period / (2 x {oversampling:g}); "
                         f"at most {max_lines(n, oversampling)} lines at this resolution): "
                         f"lower {field} or shorten the period", field=field)
    return n


def _peak_normalised(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    peak = float(np.max(np.abs(x)))
    if not (np.isfinite(peak) and peak > 0):
        raise InputError("the waveform is empty or constant zero", field="points")
    return x / peak


def crest_factor(x: np.ndarray) -> float:
    """Peak over RMS (sqrt(2) for a sine).

    >>> round(crest_factor(np.sin(np.linspace(0, 2 * np.pi, 1000, endpoint=False))), 6)
    1.414214
    """
    x = np.asarray(x, dtype=float)
    return float(np.max(np.abs(x)) / np.sqrt(np.mean(x ** 2)))


def multisine_lines(f_min_hz: float, f_max_hz: float, resolution_hz: float,
                    lines: str = "all", seed: int = 0) -> np.ndarray:
    """Harmonic numbers k (lines at k resolution_hz) in [f_min, f_max]: every line
    (``all``), the odd ones (``odd``: even lines stay free to show even-order
    distortion), or ``random_odd`` (one odd line in each group of 4 consecutive odd
    ones left out at random: detection lines for odd-order distortion too).

    >>> multisine_lines(1, 9, 1, "odd").tolist()
    [1, 3, 5, 7, 9]
    """
    k0, k1 = math.ceil(f_min_hz / resolution_hz - 1e-9), math.floor(f_max_hz / resolution_hz + 1e-9)
    if k1 > MAX_POINTS // 2:
        raise InputError(f"{f_max_hz:g} Hz at a resolution of {resolution_hz:g} Hz is line {k1}; "
                         f"a waveform of at most {MAX_POINTS} points holds lines up to "
                         f"{max_lines(MAX_POINTS, 1) + 1} (fewer with oversampling): lower "
                         "f_max_hz or coarsen the resolution", field="f_max_hz")
    k = np.arange(max(k0, 1), k1 + 1)
    if lines == "odd":
        k = k[k % 2 == 1]
    elif lines == "random_odd":
        k = k[k % 2 == 1]
        rng = np.random.default_rng(seed)
        keep = np.ones(k.size, bool)
        for g in range(0, k.size - 3, 4):
            keep[g + rng.integers(4)] = False
        k = k[keep]
    elif lines != "all":
        raise InputError(f"lines must be 'all', 'odd' or 'random_odd', got {lines!r}", field="lines")
    if k.size == 0:
        raise InputError(f"no line of resolution {resolution_hz:g} Hz lies in "
                         f"{f_min_hz:g}..{f_max_hz:g} Hz", field="f_min_hz")
    return k


def multisine(*, f_min_hz: float, f_max_hz: float, resolution_hz: float, lines: str = "all",
              lines_hz: Sequence[float] | None = None, phases: str = "random",
              crest_iterations: int = 0, seed: int = 0, n_points: int | None = None,
              oversampling: float = OVERSAMPLING) -> Waveform:
    """Flat-spectrum multisine, one period of ``1 / resolution_hz``.

    Phases ``random`` (uniform, seeded) or ``schroeder`` (phi_k = -pi k (k - 1) / F, a low
    crest factor in closed form); ``crest_iterations`` > 0 then lowers the crest factor by
    clipping the peaks and restoring the amplitude spectrum (only the phases change, so
    the excited lines and their amplitudes stay exactly as designed).
    """
    resolution_hz = _check_frequency(resolution_hz, "resolution_hz")
    period = _check_period(1.0 / resolution_hz, "resolution_hz")
    if lines_hz is not None:
        lines_hz = [_check_frequency(f, "lines_hz") for f in lines_hz]
        k_float = np.asarray(lines_hz, dtype=float) / resolution_hz
        k = np.unique(np.round(k_float).astype(int))
        bad = np.abs(k_float - np.round(k_float)) > 1e-6
        if bad.any() or k.size != k_float.size or k.size == 0 or k.min() < 1:
            raise InputError(f"every line must be a distinct positive multiple of the resolution "
                             f"{resolution_hz:g} Hz; {np.asarray(lines_hz)[bad][:3].tolist() or list(lines_hz)[:3]} "
                             "is not", field="lines_hz")
    else:
        f_min_hz = _check_frequency(f_min_hz, "f_min_hz")
        f_max_hz = _check_frequency(f_max_hz, "f_max_hz")
        if not f_max_hz >= f_min_hz:
            raise InputError(f"f_max_hz ({f_max_hz:g}) must not be below f_min_hz ({f_min_hz:g})",
                             field="f_max_hz")
        k = multisine_lines(f_min_hz, f_max_hz, resolution_hz, lines, seed)
    n = _points_for(float(k.max()) * resolution_hz, period, n_points, oversampling)
    if phases == "random":
        phi = np.random.default_rng(seed).uniform(0, 2 * np.pi, k.size)
    elif phases == "schroeder":
        m = np.arange(1, k.size + 1)
        phi = -np.pi * m * (m - 1) / k.size
    else:
        raise InputError(f"phases must be 'random' or 'schroeder', got {phases!r}", field="phases")
    spectrum = np.zeros(n // 2 + 1, complex)
    spectrum[k] = np.exp(1j * phi)
    x = np.fft.irfft(spectrum, n)
    for _ in range(int(crest_iterations)):
        x = _clip_and_restore(x, spectrum, k)
    x = _peak_normalised(x)
    return Waveform("multisine", x, period, (float(k.min() * resolution_hz), float(k.max() * resolution_hz)),
                    tuple(float(v) for v in k * resolution_hz), crest_factor(x),
                    {"phases": phases, "crest_iterations": int(crest_iterations), "seed": int(seed),
                     "lines": "explicit" if lines_hz is not None else lines})


def _clip_and_restore(x: np.ndarray, spectrum: np.ndarray, k: np.ndarray) -> np.ndarray:
    """One crest-factor step: clip at 90 % of the peak, keep the new phases of the
    excited lines with their designed amplitudes, drop everything else."""
    c = 0.9 * np.max(np.abs(x))
    X = np.fft.rfft(np.clip(x, -c, c))
    out = np.zeros_like(spectrum)
    out[k] = np.abs(spectrum[k]) * np.exp(1j * np.angle(X[k]))
    return np.fft.irfft(out, x.size)


def swept_sine(*, f_start_hz: float, f_stop_hz: float, period_s: float, law: str = "log",
               taper: float = 0.02, n_points: int | None = None,
               oversampling: float = OVERSAMPLING) -> Waveform:
    """One sweep per period from ``f_start`` to ``f_stop`` (``log`` or ``linear``), faded in
    and out over ``taper`` of the period (raised cosine) so that repeating it makes no step."""
    lo, hi = sorted((_check_frequency(f_start_hz, "f_start_hz"),
                     _check_frequency(f_stop_hz, "f_stop_hz")))
    if not hi > lo:
        raise InputError(f"a sweep needs f_start_hz != f_stop_hz, got {f_start_hz!r}, "
                         f"{f_stop_hz!r}", field="f_stop_hz")
    period_s = _check_period(period_s)
    if not 0 <= taper < 0.5:
        raise InputError(f"taper must be in [0, 0.5), got {taper!r}", field="taper")
    n = _points_for(hi, period_s, n_points, oversampling,
                    "f_stop_hz" if float(f_stop_hz) >= float(f_start_hz) else "f_start_hz")
    t = np.arange(n) / n * period_s
    f0, f1 = float(f_start_hz), float(f_stop_hz)
    if law == "linear":
        phase = 2 * np.pi * (f0 * t + 0.5 * (f1 - f0) / period_s * t ** 2)
    elif law == "log":
        r = math.log(f1 / f0) / period_s
        phase = 2 * np.pi * f0 * np.expm1(r * t) / r
    else:
        raise InputError(f"law must be 'log' or 'linear', got {law!r}", field="law")
    x = np.sin(phase) * _fade(n, taper)
    x = _peak_normalised(x)
    return Waveform("swept_sine", x, float(period_s), (lo, hi), (), crest_factor(x),
                    {"law": law, "f_start_hz": f0, "f_stop_hz": f1, "taper": taper})


def _fade(n: int, taper: float) -> np.ndarray:
    w = np.ones(n)
    m = int(round(taper * n))
    if m > 0:
        ramp = 0.5 - 0.5 * np.cos(np.pi * (np.arange(m) + 0.5) / m)
        w[:m], w[n - m:] = ramp, ramp[::-1]
    return w


def random_noise(*, f_min_hz: float, f_max_hz: float, period_s: float, seed: int = 0,
                 n_points: int | None = None, oversampling: float = OVERSAMPLING) -> Waveform:
    """Band-limited Gaussian noise, one period of ``period_s``: every line in the band with
    complex-normal amplitude (random amplitudes and phases). A record of one period is
    random (not periodic within it); more periods make it periodic noise."""
    period_s = _check_period(period_s)
    f_min_hz = _check_frequency(f_min_hz, "f_min_hz")
    f_max_hz = _check_frequency(f_max_hz, "f_max_hz")
    if not (0 < f_min_hz < f_max_hz):
        raise InputError(f"random noise needs 0 < f_min_hz < f_max_hz, got {f_min_hz!r}, "
                         f"{f_max_hz!r}", field="f_max_hz")
    n = _points_for(f_max_hz, period_s, n_points, oversampling)
    k = multisine_lines(f_min_hz, f_max_hz, 1.0 / period_s)
    rng = np.random.default_rng(seed)
    spectrum = np.zeros(n // 2 + 1, complex)
    spectrum[k] = rng.normal(size=k.size) + 1j * rng.normal(size=k.size)
    x = _peak_normalised(np.fft.irfft(spectrum, n))
    return Waveform("random", x, float(period_s), (float(f_min_hz), float(f_max_hz)), (),
                    crest_factor(x), {"seed": int(seed)})

