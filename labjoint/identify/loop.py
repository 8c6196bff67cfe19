"""Hysteresis-loop identification per cycle (seed 002, Sec. II.A, Eq. 1, Fig. 2).

Every estimator below is computed on one cycle resampled to a fixed number of points
over exactly one period (see :func:`labjoint.signal.cycles.cycles`):

- energy loss W_d: the closed-loop area, trapezoid of F dU around the cycle with the
  segment from the last point back to the first closing the loop (positive when the
  loop dissipates). For an ellipse resampled at M points the trapezoid is low by the
  factor M sin(2 pi / M) / (2 pi) (1 - 1e-4 at M = 256).
- U, F amplitudes: half peak-to-peak of the filtered cycle (seed 002's "maximum
  displacement U" and "maximum force F" of Fig. 2); the fundamental's amplitude
  (first Fourier coefficient) is reported too.
- damping C = W_d / (pi omega U^2), omega = 2 pi f, U the half peak-to-peak
  displacement (seed 002 Eq. 1); ``damping_fundamental`` uses |U_1| instead.
- stiffness: least-squares slope of F on U over the cycle (the default, the "slope of
  the hysteresis loop": for F = k U + c dU/dt it is exactly k; noise in F does not
  bias it) and the secant (F_max - F_min) / (U_max - U_min) (the loop tips of Fig. 2;
  |k + i c omega| for a viscous ellipse, equal to k for a linear spring).

Offsets: the record mean of displacement and force is removed before (AC-coupled
channels have none anyway), and every estimator here is invariant to constant offsets,
so a streamed record whose mean is not yet known gives the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import njit

from labjoint.errors import InputError
from labjoint.signal.cycles import harmonics
from labjoint.signal.steady import SteadyState

DEFAULT_STIFFNESS = "lsq"
#: The summary's quantities: key -> per-cycle field of LoopResult.
SUMMARY_FIELDS = {
    "displacement_amplitude_m": "displacement_amplitude",
    "force_amplitude_n": "force_amplitude",
    "energy_loss_j": "energy_loss",
    "damping_ns_per_m": "damping",
    "stiffness_n_per_m": "stiffness_" + DEFAULT_STIFFNESS,
    "stiffness_secant_n_per_m": "stiffness_secant",
    "stiffness_lsq_n_per_m": "stiffness_lsq",
}
PER_CYCLE = ("cycle_frequency", "displacement_amplitude", "force_amplitude", "energy_loss",
             "damping", "damping_fundamental", "stiffness_lsq", "stiffness_secant",
             "displacement_harmonics", "force_harmonics")


def loop_area(u: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Closed-loop integral of F dU per cycle (trapezoid, loop closed), J.

    ``u``, ``f``: (..., n_points) one period per row. Positive for a dissipative loop
    (F leads U). Seed 002, Fig. 2: W_d is the enclosed area.

    >>> s = 2 * np.pi * np.arange(4096) / 4096
    >>> round(float(loop_area(2 * np.cos(s), -3 * np.sin(s))), 3)  # pi * 2 * 3
    18.85
    """
    u = np.asarray(u, dtype=np.float64)
    f = np.asarray(f, dtype=np.float64)
    u = u - u[..., :1]                                  # the area is translation-invariant;
    f = f - f[..., :1]                                  # shifting avoids cancellation
    # sum_j (F_j + F_j+1)/2 (U_j+1 - U_j) around the closed loop = the shoelace form
    inner = np.sum(f[..., :-1] * u[..., 1:] - f[..., 1:] * u[..., :-1], axis=-1)
    return 0.5 * (inner + f[..., -1] * u[..., 0] - f[..., 0] * u[..., -1])


def cycle_metrics(u: np.ndarray, f: np.ndarray, frequency_hz: float,
                  n_harmonics: int = 5) -> dict[str, np.ndarray]:
    """Per-cycle loop quantities from resampled cycles ``u`` (m), ``f`` (N): (n_cycles, M)."""
    if u.shape != f.shape or u.ndim != 2:
        raise InputError(f"displacement and force cycles must share a 2-D shape, got "
                         f"{u.shape} and {f.shape}", field="force")
    uc = u - u.mean(axis=1, keepdims=True)
    fc = f - f.mean(axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        k_lsq = np.einsum("ij,ij->i", uc, fc) / np.einsum("ij,ij->i", uc, uc)
    return _derived(0.5 * (u.max(axis=1) - u.min(axis=1)), 0.5 * (f.max(axis=1) - f.min(axis=1)),
                    loop_area(u, f), k_lsq, harmonics(u, n_harmonics),
                    harmonics(f, n_harmonics), frequency_hz)


def _derived(u_amp: np.ndarray, f_amp: np.ndarray, w: np.ndarray, k_lsq: np.ndarray,
             uh: np.ndarray, fh: np.ndarray, frequency_hz: float) -> dict[str, np.ndarray]:
    """The per-cycle dictionary, with damping (seed 002 Eq. 1) and the secant."""
    omega = 2.0 * np.pi * frequency_hz
    with np.errstate(divide="ignore", invalid="ignore"):
        return {
            "displacement_amplitude": u_amp,
            "force_amplitude": f_amp,
            "energy_loss": w,
            "damping": w / (np.pi * omega * u_amp ** 2),                    # seed 002 Eq. 1
            "damping_fundamental": w / (np.pi * omega * np.abs(uh[:, 0]) ** 2),
            "stiffness_lsq": k_lsq,
            "stiffness_secant": f_amp / u_amp,
            "displacement_harmonics": uh,
            "force_harmonics": fh,
        }


def loop_metrics(displacement: np.ndarray, force: np.ndarray, bounds: np.ndarray,
                 frequency_hz: float, n_points: int = 256, n_harmonics: int = 5,
                 *, offset: float = 0.0) -> dict[str, np.ndarray]:
    """:func:`cycle_metrics` of the cycles ``bounds`` straight from the samples.

    Same numbers as ``cycle_metrics(cycles(u, bounds), cycles(F, bounds))`` (same
    Catmull-Rom resampling), in one compiled pass without materialising the cycles: the
    hot loop of the streamed pipeline. ``bounds`` must be checked by the caller (in
    [1, n - 3] relative to ``offset``, increasing).
    """
    b = np.asarray(bounds, dtype=np.float64) - float(offset)
    m, h = int(n_points), int(n_harmonics)
    n = max(b.size - 1, 0)
    scalars = np.empty((n, 4))
    uh = np.empty((n, h), dtype=np.complex128)
    fh = np.empty((n, h), dtype=np.complex128)
    j = np.arange(m)
    angle = 2 * np.pi * ((np.arange(1, h + 1)[:, None] * j[None, :]) % m) / m
    _loop_kernel(np.ascontiguousarray(displacement, dtype=np.float64),
                 np.ascontiguousarray(force, dtype=np.float64), b, m,
                 np.cos(angle), np.sin(angle), scalars, uh, fh)
    u_amp, f_amp, w, k_lsq = scalars.T
    return _derived(u_amp, f_amp, w, k_lsq, uh, fh, frequency_hz)


@njit(cache=True, fastmath=True, nogil=True)
def _loop_kernel(xu, xf, bounds, m, cos_t, sin_t, scalars, uh, fh):  # pragma: no cover
    # fastmath lets the sums vectorise (about 2x); it only reorders additions, which
    # changes results by about 1e-15 relative. No NaN or inf reaches here (validated).
    # Each loop below is kept simple enough to vectorise on its own: the Catmull-Rom
    # weights, the interpolation (indirect loads), the sums, the extremes, the harmonics.
    n_h = cos_t.shape[0]
    ub = np.empty(m)
    fb = np.empty(m)
    at = np.empty(m, dtype=np.int64)
    w0 = np.empty(m)
    w1 = np.empty(m)
    w2 = np.empty(m)
    w3 = np.empty(m)
    for k in range(bounds.size - 1):
        t0 = bounds[k]
        dt = (bounds[k + 1] - t0) / m
        for j in range(m):                           # Catmull-Rom, as signal.cycles.cycles
            t = t0 + j * dt
            i = int(t)                               # t >= 1: truncation is the floor
            s = t - i
            at[j] = i
            w0[j] = 0.5 * s * (-1.0 + s * (2.0 - s))
            w1[j] = 1.0 + 0.5 * s * s * (-5.0 + 3.0 * s)
            w2[j] = 0.5 * s * (1.0 + s * (4.0 - 3.0 * s))
            w3[j] = 0.5 * s * s * (s - 1.0)
        for j in range(m):
            i = at[j]
            if i < 1:        # never (bounds >= 1): an exit that keeps this loop scalar, whose
                break        # 8 loads a point beat vector gathers (726 vs 832 ns a cycle, EPYC)
            ub[j] = w0[j] * xu[i - 1] + w1[j] * xu[i] + w2[j] * xu[i + 1] + w3[j] * xu[i + 2]
            fb[j] = w0[j] * xf[i - 1] + w1[j] * xf[i] + w2[j] * xf[i + 1] + w3[j] * xf[i + 2]
        u0, f0 = ub[0], fb[0]
        area = 0.0                                   # shoelace on values shifted by the
        su = sf = suu = suf = 0.0                    # first point (no cancellation); the
        for j in range(1, m):                        # terms with the first point are 0
            du = ub[j] - u0
            df = fb[j] - f0
            area += (fb[j - 1] - f0) * du - df * (ub[j - 1] - u0)
            su += du
            sf += df
            suu += du * du
            suf += du * df
        u_hi = u_lo = u0
        f_hi = f_lo = f0
        for j in range(1, m):
            u_hi = ub[j] if ub[j] > u_hi else u_hi
            u_lo = ub[j] if ub[j] < u_lo else u_lo
            f_hi = fb[j] if fb[j] > f_hi else f_hi
            f_lo = fb[j] if fb[j] < f_lo else f_lo
        scalars[k, 0] = 0.5 * (u_hi - u_lo)
        scalars[k, 1] = 0.5 * (f_hi - f_lo)
        scalars[k, 2] = 0.5 * area
        var = suu - su * su / m
        scalars[k, 3] = (suf - su * sf / m) / var if var > 0.0 else np.nan
        for h in range(n_h):
            ur = ui = fr = fi = 0.0
            for j in range(m):
                c = cos_t[h, j]
                sn = sin_t[h, j]
                ur += ub[j] * c
                ui += ub[j] * sn
                fr += fb[j] * c
                fi += fb[j] * sn
            uh[k, h] = complex(ur, -ui) * (2.0 / m)
            fh[k, h] = complex(fr, -fi) * (2.0 / m)


@dataclass
class LoopResult:
    """Hysteresis-loop results: per-cycle arrays, the steady mask and their summary.

    ``bounds`` are fractional sample indices of the cycle starts (n_cycles + 1).
    ``summary`` holds exactly: frequency_hz, displacement_amplitude_m,
    force_amplitude_n, energy_loss_j, damping_ns_per_m, stiffness_n_per_m (the
    least-squares slope by default), stiffness_secant_n_per_m, stiffness_lsq_n_per_m,
    cycles (number of steady cycles), and ``<key>_std`` for every float key: mean and
    sample standard deviation over the steady cycles; the pipeline adds the
    uncertainty and resolution of W and C (:func:`labjoint.identify.resolution.resolution`:
    energy_loss_j_uncertainty, energy_loss_j_resolution, energy_loss_j_uncertainty_phase,
    damping_ns_per_m_uncertainty, below_resolution, cycles_below_resolution). ``frequency_hz`` is the
    frequency used in Eq. 1; its std is that of the per-cycle measured frequencies.
    """

    frequency_hz: float
    sample_rate_hz: float
    bounds: np.ndarray
    valid: np.ndarray
    steady: np.ndarray
    cycle_frequency: np.ndarray
    displacement_amplitude: np.ndarray
    force_amplitude: np.ndarray
    energy_loss: np.ndarray
    damping: np.ndarray
    damping_fundamental: np.ndarray
    stiffness_lsq: np.ndarray
    stiffness_secant: np.ndarray
    displacement_harmonics: np.ndarray
    force_harmonics: np.ndarray
    steady_state: SteadyState
    summary: dict[str, float | int] = field(default_factory=dict)
    #: per-cycle standard uncertainty of W (J) and W below its resolution
    #: (:mod:`labjoint.identify.resolution`); filled by the pipeline
    energy_loss_uncertainty: np.ndarray = field(default_factory=lambda: np.empty(0))
    below_resolution: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=bool))
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def n_cycles(self) -> int:
        return int(self.energy_loss.size)

    @property
    def stiffness(self) -> np.ndarray:
        """Per-cycle stiffness by the default estimator (``DEFAULT_STIFFNESS``)."""
        return getattr(self, "stiffness_" + DEFAULT_STIFFNESS)

    @property
    def phase(self) -> np.ndarray:
        """Per-cycle phase of the force fundamental ahead of the displacement's (rad);
        the loss angle, positive for a dissipative loop."""
        return np.angle(self.force_harmonics[:, 0] * np.conj(self.displacement_harmonics[:, 0]))

    @property
    def displacement_fundamental(self) -> np.ndarray:
        return np.abs(self.displacement_harmonics[:, 0])

    @property
    def force_fundamental(self) -> np.ndarray:
        return np.abs(self.force_harmonics[:, 0])


def summarize(result: LoopResult) -> dict[str, float | int]:
    """Mean and std over ``result.steady`` cycles, under the fixed summary keys."""
    mask = result.steady
    n = int(mask.sum())
    if n == 0:
        raise InputError("no steady cycle to summarise", field="steady")
    ddof = 1 if n > 1 else 0
    out: dict[str, float | int] = {
        "frequency_hz": float(result.frequency_hz),
        "frequency_hz_std": float(np.std(result.cycle_frequency[mask], ddof=ddof)),
    }
    for key, name in SUMMARY_FIELDS.items():
        vals = getattr(result, name)[mask]
        out[key] = float(np.mean(vals))
        out[key + "_std"] = float(np.std(vals, ddof=ddof))
    out["cycles"] = n
    return out
