"""The noise floor of steady-sine runs: the NRMSE that measurement noise alone would leave.

Method (cycle-to-cycle scatter, slow drift removed). The steady cycles of a run, from the
displacement fundamental's upward zero crossings, are resampled to M points each (M: the
nearest integer to the samples per cycle; the Catmull-Rom interpolation of
:func:`labjoint.signal.cycles.cycles`) and taken in windows of ``WINDOW_CYCLES``
consecutive cycles. At each of the M phase points a straight line over the window's cycles
(the mean cycle plus a linear trend per phase) is the deterministic part; a slow drift
(wear, thermal) moves the loop smoothly over the window and goes into the trend, where a
plain scatter about the mean cycle would count it as noise. What is left scatters from
cycle to cycle; its variance over the window, with (n_cycles - 2) M degrees of freedom,
divided by the interpolation's noise gain (mean over the resampled points of the sum of
the squared Catmull-Rom weights, < 1), estimates the white-noise variance of the raw
samples.

Measurement noise is stationary, while what else can scatter (a decaying start-up
transient of the rig's low modes, a beat with a free vibration) comes and goes: windows
whose scatter exceeds the quietest third's (pooled) by more than an F-test allows
(one-sided, ``EXCESS_P``) are left out, and the noise variance is the scatter pooled over
the windows that remain. Resampling reads its own interpolation error as scatter
where a cycle holds few samples of a sharp force (a slip law's kinks); the force's
variance is then taken from raw samples a whole number of them apart
(:func:`lag_variance`) where that is smaller.

Displacement noise reaches the residual through the model (F_model is evaluated on the
measured displacement), approximately as the joint's stiffness times that noise, so the
force-equivalent noise of a run is sigma_F^2 + k^2 sigma_u^2 with k the loop's
least-squares stiffness (seed 002's loop slope) and sigma_u from the displacement's
quietest window (:func:`quietest_variance`). The pooled noise floor
(:func:`labjoint.compare.measurement.noise_floor`) is sqrt(sum_runs n_r sigma_r^2 /
sum_runs sum F^2) over the same steady samples as the NRMSE (design.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from math import comb

import numpy as np
from scipy import stats

from labjoint.signal.cycles import cycles as resample_cycles

WINDOW_CYCLES = 8
MIN_WINDOW_CYCLES = 5
TREND_DEGREE = 2
EXCESS_P = 1e-3
RESOLUTION = 1e-7
MAX_DIFF_ORDER = 6
#: the lag method needs this many cycles of overlap and a lag within this of whole samples
LAG_OVERLAP = 3
LAG_TOL = 0.25
#: a period within this of whole samples is left to the scatter (no interpolation error)
WHOLE_TOL = 0.01


def interpolation_gain(bounds: np.ndarray, m: int) -> float:
    """Mean sum of squared Catmull-Rom weights at the resampled points (white-noise gain)."""
    t = bounds[:-1, None] + np.arange(m)[None, :] * (np.diff(bounds)[:, None] / m)
    s = t - np.floor(t)
    w0 = 0.5 * s * (-1.0 + s * (2.0 - s))
    w1 = 1.0 + 0.5 * s * s * (-5.0 + 3.0 * s)
    w2 = 0.5 * s * (1.0 + s * (4.0 - 3.0 * s))
    w3 = 0.5 * s * s * (s - 1.0)
    return float(np.mean(w0 ** 2 + w1 ** 2 + w2 ** 2 + w3 ** 2))


def _detrended(c: np.ndarray, degree: int) -> np.ndarray:
    """Cycles (n, M) minus a polynomial of ``degree`` over the cycles at every phase point
    (orthonormal basis from a QR of the small n x (degree + 1) Vandermonde matrix)."""
    k = np.arange(c.shape[0]) - 0.5 * (c.shape[0] - 1)
    q, _ = np.linalg.qr(np.vander(k, degree + 1))
    return c - q @ (q.T @ c)


def window_scatter(x: np.ndarray, groups: Sequence[np.ndarray], window_cycles: int = WINDOW_CYCLES
                   ) -> list[tuple[float, int, int, int, int, float]]:
    """(noise variance, degrees of freedom, group, first cycle, end cycle, mean square of the
    signal) of each window (module docstring). ``groups``: fractional bounds of consecutive cycles (each group
    n_cycles + 1 values, interpolation neighbours inside ``x``)."""
    out = []
    for gi, g in enumerate(groups):
        n = g.size - 1
        if n < MIN_WINDOW_CYCLES:
            continue
        m = max(8, int(round(float(np.mean(np.diff(g))))))
        edges = np.linspace(0, n, max(1, n // window_cycles) + 1).round().astype(int)
        for a, b in zip(edges[:-1], edges[1:]):
            if b - a < MIN_WINDOW_CYCLES:
                continue
            bw = g[a:b + 1]
            c = resample_cycles(x, bw, m, check=False)
            r = _detrended(c, TREND_DEGREE)
            dof = (b - a - TREND_DEGREE - 1) * m
            out.append((float(np.sum(r * r)) / dof / interpolation_gain(bw, m), dof, gi, int(a), int(b),
                        float(np.mean(c * c))))
    return out


def _stationary(win: list[tuple[float, int, int, int, int, float]]) -> np.ndarray:
    """Per window: scatter within the F-test allowance of the quietest third's (a scatter
    below ``RESOLUTION`` of the signal's rms counts as none)."""
    var = np.array([w[0] for w in win])
    dof = np.array([w[1] for w in win])
    quiet = np.argsort(var)[:max(1, len(win) // 3)]
    ref_dof = int(dof[quiet].sum())
    ref = float(np.sum(var[quiet] * dof[quiet]) / ref_dof)
    ref = max(ref, RESOLUTION ** 2 * max(w[5] for w in win))
    return var <= ref * stats.f.ppf(1.0 - EXCESS_P, dof, ref_dof)


def stationary_cycles(x: np.ndarray, groups: Sequence[np.ndarray],
                      window_cycles: int = WINDOW_CYCLES) -> list[np.ndarray]:
    """Per group, per cycle: False where the cycle lies in a window with excess scatter (a
    transient), True otherwise (also where a group is too short to judge)."""
    keep = [np.ones(g.size - 1, bool) for g in groups]
    win = window_scatter(np.asarray(x, dtype=float), groups, window_cycles)
    if win:
        for w, ok in zip(win, _stationary(win)):
            if not ok:
                keep[w[2]][w[3]:w[4]] = False
    return keep


def scatter_variance(x: np.ndarray, groups: Sequence[np.ndarray],
                     window_cycles: int = WINDOW_CYCLES) -> tuple[float, int, int]:
    """Noise variance of ``x`` over the given cycles, windows with excess scatter left out
    (module docstring): (variance, cycles used, windows used)."""
    win = window_scatter(np.asarray(x, dtype=float), groups, window_cycles)
    if not win:
        return float("nan"), 0, 0
    keep = _stationary(win)
    var = np.array([w[0] for w in win])[keep]
    dof = np.array([w[1] for w in win])[keep]
    cyc = sum(w[4] - w[3] for w, k in zip(win, keep) if k)
    return float(np.sum(var * dof) / dof.sum()), int(cyc), int(keep.sum())


def quietest_variance(x: np.ndarray, groups: Sequence[np.ndarray],
                      window_cycles: int = WINDOW_CYCLES) -> float:
    """The smallest window scatter (for the displacement, whose own noise is far below a
    transient's motion, so that a transient reaching every window inflates the F-test's
    reference; the minimum of several estimates is biased low by ~sqrt(2/dof), a few %)."""
    win = window_scatter(np.asarray(x, dtype=float), groups, window_cycles)
    return min(w[0] for w in win) if win else float("nan")


#: the method in words (the sine kind's ``noise_method``)
METHOD = ("cycle-to-cycle scatter: resampled steady cycles minus a per-phase linear "
          f"trend over windows of {WINDOW_CYCLES} cycles, windows with excess scatter "
          f"left out (F-test, p < {EXCESS_P:g}), or for the force the raw-sample "
          "difference at a lag of whole cycles (difference method) where smaller; force "
          "noise plus displacement noise times the loop stiffness")


def difference_variance(x: np.ndarray) -> float:
    """White-noise variance by the difference method: min over d of the robust variance
    (1.4826 x the median absolute deviation, squared) of diff^d x, divided by C(2d, d).
    The median ignores the sparse spikes a stick-slip kink puts into the differences."""
    x = np.asarray(x, dtype=float)
    best = float("inf")
    for d in range(1, MAX_DIFF_ORDER + 1):
        if x.size <= d + 8:
            break
        dx = np.diff(x, d)
        mad = 1.4826 * float(np.median(np.abs(dx - np.median(dx))))
        best = min(best, mad * mad / comb(2 * d, d))
    return best if np.isfinite(best) else float("nan")


def lag_variance(x: np.ndarray, groups: Sequence[np.ndarray]) -> float:
    """White-noise variance from raw samples, no interpolation: within each group of
    consecutive cycles, the lag of q cycles closest to a whole number of samples L (q
    leaving ``LAG_OVERLAP`` cycles of overlap, |qP - L| <= ``LAG_TOL`` samples), the
    difference x[i + L] - x[i] (the noise times sqrt(2), plus what a fraction of a sample
    of shift leaves of the signal: smooth, or sparse spikes at a slip law's kinks) by the
    difference method, halved; pooled over the groups by their samples. Groups of a
    whole number of samples per cycle are left out (NaN if all are): resampling is exact
    there and the scatter is the better estimate (the difference method's median is
    less efficient, and its minimum over orders reads low by 5-15 %).

    At few samples per cycle the cycle-to-cycle scatter reads the resampling's error as
    noise (a Jenkins force at 22 samples per cycle: 1.5x the noise, enough to call a model
    missing a viscous term adequate); this reads 1.1x there and agrees where the scatter is
    right, and :meth:`labjoint.compare.prepared.PreparedRun.noise` takes the smaller."""
    x = np.asarray(x, dtype=float)
    num = den = 0.0
    for g in groups:
        n = g.size - 1
        per = float(np.mean(np.diff(g)))
        if abs(per - round(per)) <= WHOLE_TOL:
            continue                # whole samples per cycle: resampling is exact there
        best = None
        for q in range(1, n - LAG_OVERLAP + 1):
            lag = int(round(q * per))
            off = abs(q * per - lag)
            if off <= LAG_TOL and (best is None or off < best[0] - 1e-9):
                best = (off, lag)
        if best is None:
            continue
        a, b = int(np.ceil(g[0])), int(np.floor(g[-1]))
        d = x[a + best[1]:b] - x[a:b - best[1]]
        v = difference_variance(d) / 2.0
        if np.isfinite(v):
            num += v * d.size
            den += d.size
    return num / den if den > 0 else float("nan")
