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


def period_mean(u: np.ndarray, sample_rate_hz: float, frequency_hz: float) -> np.ndarray:
    """The running mean of ``u`` over one period (fractional, centred on each sample).

    A whole-period average removes the fundamental and every harmonic, leaving the
    cycle's own centre: subtracting it keeps a sliding joint's slow drift out of each
    quarter's u_i and U (seed 002 Eq. 5 measures u from the cycle's centre). Where the
    window would leave the record the nearest whole window's mean is used.

    >>> fs, f = 1000.0, 30.0
    >>> t = np.arange(2000) / fs
    >>> u = np.sin(2 * np.pi * f * t) + 0.2 * t          # a sine on a drift
    >>> bool(np.allclose(period_mean(u, fs, f)[200:1800], 0.2 * t[200:1800], atol=1e-3))
    True
    """
    u = np.asarray(u, dtype=float)
    period = sample_rate_hz / frequency_hz
    if u.size < period + 2:
        return np.full(u.shape, u.mean() if u.size else 0.0)
    # C(x): integral of the sample-and-hold signal from 0 to x (samples)
    c = np.concatenate(([0.0], np.cumsum(u)))
    x = np.arange(u.size) + 0.5
    lo = np.clip(x - period / 2, 0.0, u.size - period)
    grid = np.arange(c.size, dtype=float)
    return (np.interp(lo + period, grid, c) - np.interp(lo, grid, c)) / period


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


#: Harmonics (of the drive frequency) the band-limited peak fit may use.
MAX_PEAK_HARMONICS = 15
#: Points per sample on which the fitted cycle is searched for its maximum.
_GRID_PER_SAMPLE = 64


def band_limited_peaks(u: np.ndarray, peak: np.ndarray, sample_rate_hz: float,
                       frequency_hz: float, max_hz: float | None = None, *,
                       half_range: bool = False) -> np.ndarray:
    """Each cycle's maximum U of the band-limited displacement, not of its samples.

    The largest sample of a cycle falls short of the waveform's peak by up to
    1 - cos(pi f / fs) (1.2 % at 20 samples per cycle, so W = 2 K_t U^2 of seed 002 Eq. 7
    2.4 % low). Around each sample maximum ``peak[k]``, one period of ``u`` is fitted
    by least squares with a constant and the harmonics h f below ``max_hz`` (the
    analysis low-pass; at most :data:`MAX_PEAK_HARMONICS`, and below 0.45 fs), and the
    maximum of that series within a sample of ``peak[k]`` is returned. Windows are the
    same sample offsets for every cycle, so one pseudo-inverse serves them all; a window
    cut by the record's ends is shifted inside it. ``half_range``: half the fitted
    cycle's peak-to-peak instead (its minimum searched over the whole period), the
    amplitude of a cycle whose maximum and minimum are not symmetric about its mean.

    >>> fs, f = 8000.0, 400.0                     # 20 samples per cycle
    >>> t = np.arange(400) / fs
    >>> u = 2e-6 * np.sin(2 * np.pi * f * t + np.pi / 20)   # peaks between samples
    >>> p = np.flatnonzero((u[1:-1] > u[:-2]) & (u[1:-1] >= u[2:])) + 1
    >>> float(u[p].max() / 2e-6) < 0.988, bool(np.allclose(band_limited_peaks(u, p, fs, f), 2e-6))
    (True, True)
    """
    u = np.asarray(u, dtype=float)
    peak = np.asarray(peak, dtype=np.int64)
    if peak.size == 0:
        return np.zeros(0)
    period = sample_rate_hz / frequency_hz
    top = 0.45 * sample_rate_hz if max_hz is None else min(max_hz, 0.45 * sample_rate_hz)
    n_h = int(max(1, min(MAX_PEAK_HARMONICS, np.floor(top / frequency_hz),
                         (int(period) - 1) // 4)))
    half = int(np.ceil(period / 2))
    offsets = np.arange(-half, half + 1)
    if offsets.size > u.size:
        raise InputError(f"record of {u.size} samples is shorter than one period "
                         f"({period:.1f} samples)", field="displacement")
    w = 2 * np.pi * frequency_hz / sample_rate_hz          # rad per sample
    h = np.arange(1, n_h + 1)

    def design(tau: np.ndarray) -> np.ndarray:
        ph = np.outer(tau, h) * w
        return np.hstack([np.ones((tau.size, 1)), np.cos(ph), np.sin(ph)])

    grid = np.linspace(-1.0, 1.0, 2 * _GRID_PER_SAMPLE + 1)
    whole = np.linspace(offsets[0], offsets[-1], 8 * (offsets.size - 1) + 1)

    def value(coef: np.ndarray) -> np.ndarray:
        top = (design(grid) @ coef).max(axis=0)
        return (top - (design(whole) @ coef).min(axis=0)) / 2 if half_range else top

    out = np.empty(peak.size)
    lo = peak + offsets[0]
    hi = peak + offsets[-1]
    inside = (lo >= 0) & (hi < u.size)
    if inside.any():
        coef = np.linalg.pinv(design(offsets.astype(float))) @ u[peak[inside][None, :]
                                                                  + offsets[:, None]]
        out[inside] = value(coef)
    for k in np.flatnonzero(~inside):                      # windows at the record's ends
        start = int(min(max(lo[k], 0), u.size - offsets.size))
        tau = np.arange(start, start + offsets.size) - peak[k]
        coef = np.linalg.lstsq(design(tau.astype(float)), u[start:start + offsets.size],
                               rcond=None)[0]
        out[k] = float(value(coef))
    return out
