"""Per-cycle arrays: each cycle resampled to a fixed number of points, and its harmonics."""

from __future__ import annotations

import numpy as np
from numba import njit

from labjoint.errors import InputError
from labjoint.signal import validate

DEFAULT_POINTS = 256


def cycles(x: np.ndarray, bounds: np.ndarray, n_points: int = DEFAULT_POINTS,
           *, offset: float = 0.0, check: bool = True) -> np.ndarray:
    """Cycles of ``x`` resampled to ``n_points`` each: shape (n_cycles, n_points).

    Cycle k is sampled at ``bounds[k] + j (bounds[k+1] - bounds[k]) / n_points``,
    j = 0..n_points-1 (exactly one period, end point excluded) by cubic (Catmull-Rom)
    interpolation. ``x`` may be (n,) or (n_channels, n) -> (n_channels, n_cycles,
    n_points). ``offset`` is the absolute index of ``x[..., 0]`` when ``bounds`` are
    absolute indices into a longer record. ``check=False`` skips the input checks
    (for callers that already validated ``x`` and ``bounds``).

    >>> x = np.sin(2 * np.pi * np.arange(1000) / 100)
    >>> c = cycles(x, np.array([100.0, 200.0, 300.0]), 4)
    >>> (c.round(6) + 0.0).tolist()
    [[0.0, 1.0, 0.0, -1.0], [0.0, 1.0, 0.0, -1.0]]
    """
    if not check:
        arr = np.asarray(x, dtype=np.float64)
        b = np.asarray(bounds, dtype=np.float64) - float(offset)
    else:
        arr = validate.signal(x, "x", ndim=(1, 2), min_samples=4)
        b = validate.signal(bounds, "bounds", min_samples=1) - float(offset)
    if isinstance(n_points, bool) or not isinstance(n_points, (int, np.integer)) or n_points < 4:
        raise InputError(f"must be an integer >= 4, got {n_points!r}", field="n_points")
    if b.size and (np.any(np.diff(b) <= 0) or b[0] < 1.0 or b[-1] > arr.shape[-1] - 3):
        raise InputError(f"must increase and lie in [1, {arr.shape[-1] - 3}] (relative to "
                         "offset) so every cycle has interpolation neighbours", field="bounds")
    flat = arr.reshape(-1, arr.shape[-1])
    out = np.empty((flat.shape[0], max(b.size - 1, 0), int(n_points)))
    for ch in range(flat.shape[0]):
        _resample(np.ascontiguousarray(flat[ch]), b, int(n_points), out[ch])
    return out[0] if arr.ndim == 1 else out


@njit(cache=True)
def _resample(x, bounds, n_points, out):  # pragma: no cover - compiled
    for k in range(bounds.size - 1):
        t0 = bounds[k]
        dt = (bounds[k + 1] - t0) / n_points
        for j in range(n_points):
            t = t0 + j * dt
            i = int(np.floor(t))
            u = t - i
            p0 = x[i - 1]
            p1 = x[i]
            p2 = x[i + 1]
            p3 = x[i + 2]
            out[k, j] = p1 + 0.5 * u * (p2 - p0 + u * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3
                                                      + u * (3.0 * (p1 - p2) + p3 - p0)))


def harmonics(cyc: np.ndarray, n_harmonics: int = 5) -> np.ndarray:
    """Complex amplitudes c_h, h = 1..n_harmonics, of each resampled cycle.

    A cycle is ``sum_h |c_h| cos(h 2 pi s + angle(c_h))`` (+ mean), s in [0, 1) the
    fraction of the cycle from its start. Shape (..., n_harmonics).

    >>> s = np.arange(64) / 64
    >>> c = harmonics(np.array([2 * np.cos(2 * np.pi * s) - 0.5 * np.sin(6 * np.pi * s)]), 3)
    >>> np.abs(c).round(9).tolist(), round(float(np.angle(c[0, 2])), 6)
    ([[2.0, 0.0, 0.5]], 1.570796)
    """
    arr = np.asarray(cyc, dtype=np.float64)
    n = arr.shape[-1]
    if isinstance(n_harmonics, bool) or not isinstance(n_harmonics, (int, np.integer)) \
            or not 1 <= n_harmonics < n / 2:
        raise InputError(f"must be an integer from 1 to {n // 2 - 1} for {n} points per cycle,"
                         f" got {n_harmonics!r}", field="n_harmonics")
    return np.fft.rfft(arr, axis=-1)[..., 1:n_harmonics + 1] * (2.0 / n)
