"""Rising quarter cycles of a record (seed 002 Eq. 5): from each upward zero crossing of
the displacement to the next maximum, the pieces the stick-slip method integrates."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from labjoint.errors import InputError


@dataclass
class Quarters:
    """Rising quarter cycles cut from a record: flat u (each starting at 0) and indices."""

    displacement_m: np.ndarray
    starts: np.ndarray          # first flat index of each quarter
    crossing_sample: np.ndarray  # fractional sample index of each upward zero crossing
    peak_sample: np.ndarray      # sample index of each quarter's maximum


def rising_quarters(displacement_m: np.ndarray, sample_rate_hz: float,
                    frequency_hz: float) -> Quarters:
    """Cut every rising quarter cycle (upward zero crossing to the next maximum), Eq. 5.

    The record is centred on its mean; u_1 = 0 is the interpolated crossing, followed by
    the measured samples up to the cycle's maximum. Crossings closer than half a period
    to the previous one (noise chatter) are dropped, as are quarters cut by the record end.
    """
    if not (np.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise InputError(f"sample rate must be positive, got {sample_rate_hz}",
                         field="sample_rate_hz")
    if not (np.isfinite(frequency_hz) and 0 < frequency_hz < sample_rate_hz / 8):
        raise InputError(f"frequency must be in (0, fs/8), got {frequency_hz} Hz",
                         field="frequency_hz")
    u = np.asarray(displacement_m, dtype=float)
    u = u - u.mean()
    period = sample_rate_hz / frequency_hz
    i = np.flatnonzero((u[:-1] < 0) & (u[1:] >= 0)) + 1     # u[i-1] < 0 <= u[i]
    if i.size:
        gaps = np.diff(i, prepend=-(10 * int(period) + 10))
        i = i[gaps >= 0.5 * period]
    win = int(np.ceil(0.5 * period))
    i = i[i + win <= u.size]
    if i.size == 0:
        return Quarters(np.zeros(0), np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64))
    peak = _peaks(u, i, win)
    frac = u[i] / (u[i] - u[i - 1])                         # crossing at i - frac
    lengths = peak - i + 2                                  # u_1 = 0 plus samples i..peak
    starts = np.concatenate(([0], np.cumsum(lengths)[:-1])).astype(np.int64)
    flat = np.empty(int(lengths.sum()))
    _gather(u, i, peak, starts, flat)
    return Quarters(flat, starts, i - frac, peak)


@njit(cache=True)
def _peaks(u, first, win):  # pragma: no cover
    """Index of the maximum of u in [first_k, first_k + win) for every k."""
    out = np.empty(first.size, np.int64)
    for k in range(first.size):
        best = first[k]
        for j in range(first[k] + 1, first[k] + win):
            if u[j] > u[best]:
                best = j
        out[k] = best
    return out


@njit(cache=True)
def _gather(u, first, peak, starts, flat):  # pragma: no cover
    """flat[starts_k] = 0 (u_1), then u[first_k .. peak_k]."""
    for k in range(first.size):
        p = starts[k]
        flat[p] = 0.0
        for j in range(first[k], peak[k] + 1):
            p += 1
            flat[p] = u[j]
