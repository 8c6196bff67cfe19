"""Min/max-preserving decimation for plots: every peak of the raw signal survives.

The samples are cut into buckets of equal size; each bucket keeps its minimum and its
maximum, in time order, so a plot of at most ``max_points`` points has the same
envelope as the full record (a plain stride would drop peaks). Long records are read
a chunk at a time, so memory stays bounded whatever the run's length.

>>> import numpy as np
>>> x = np.array([0., 5., 1., -3., 2., 2., 9., 0.])
>>> minmax_indices(x, bucket=4).tolist()
[1, 3, 6, 7]
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

#: Samples read at once while decimating (per channel).
CHUNK_SAMPLES = 1 << 20


def bucket_size(n: int, max_points: int) -> int:
    """Samples per bucket so that ``n`` samples give at most ``max_points`` points
    (1: no decimation needed).

    >>> bucket_size(1000, 2000), bucket_size(1000, 100), bucket_size(1001, 100)
    (1, 20, 21)
    """
    if n <= max_points:
        return 1
    return math.ceil(n / (max_points // 2))


def minmax_indices(values: np.ndarray, bucket: int) -> np.ndarray:
    """Sorted indices of each bucket's minimum and maximum (one index when they coincide)."""
    n = values.size
    if bucket <= 1 or n == 0:
        return np.arange(n)
    full = n // bucket
    idx = []
    if full:
        body = values[:full * bucket].reshape(full, bucket)
        base = np.arange(full) * bucket
        idx += [base + np.argmin(body, axis=1), base + np.argmax(body, axis=1)]
    if n > full * bucket:
        tail = values[full * bucket:]
        idx += [np.array([full * bucket + int(np.argmin(tail)),
                          full * bucket + int(np.argmax(tail))])]
    return np.unique(np.concatenate(idx))


def decimate(read: Callable[[int, int], np.ndarray], start: int, stop: int,
             max_points: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Sample indices and values of ``read(a, b)`` over ``[start, stop)``, min/max
    decimated to at most ``max_points`` points; also the bucket size (1: raw)."""
    n = max(0, stop - start)
    bucket = bucket_size(n, max_points)
    if bucket == 1:
        return np.arange(start, stop), np.asarray(read(start, stop), dtype=float), 1
    step = bucket * max(1, CHUNK_SAMPLES // bucket)
    idx_parts, val_parts = [], []
    for a in range(start, stop, step):
        b = min(a + step, stop)
        chunk = np.asarray(read(a, b), dtype=float)
        local = minmax_indices(chunk, bucket)
        idx_parts.append(a + local)
        val_parts.append(chunk[local])
    return np.concatenate(idx_parts), np.concatenate(val_parts), bucket
