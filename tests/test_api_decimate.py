"""Min/max decimation: bounded point count, every bucket's extremes kept, chunking invisible."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.api import decimate as dec


@pytest.mark.parametrize("n,max_points", [(10, 10), (11, 10), (1000, 100), (12345, 2000),
                                          (99991, 37), (5, 1000)])
def test_point_count_bound_and_bucket_extremes(n, max_points):
    rng = np.random.default_rng(n)
    x = rng.standard_normal(n)
    idx, vals, bucket = dec.decimate(lambda a, b: x[a:b], 0, n, max_points)
    assert len(idx) <= max(max_points, n if n <= max_points else 0)
    assert np.all(np.diff(idx) > 0) and np.array_equal(vals, x[idx])
    for a in range(0, n, bucket):                      # each bucket keeps its min and max
        seg = x[a:a + bucket]
        inside = vals[(idx >= a) & (idx < a + bucket)]
        assert inside.max() == seg.max() and inside.min() == seg.min()


def test_short_ranges_are_returned_raw():
    x = np.arange(50.0)
    idx, vals, bucket = dec.decimate(lambda a, b: x[a:b], 10, 30, 100)
    assert bucket == 1 and np.array_equal(idx, np.arange(10, 30)) and np.array_equal(vals, x[10:30])


def test_chunked_reading_gives_the_same_points(monkeypatch):
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.standard_normal(100_003))
    reads = []

    def read(a, b):
        reads.append(b - a)
        return x[a:b]

    whole = dec.decimate(read, 7, x.size, 500)
    monkeypatch.setattr(dec, "CHUNK_SAMPLES", 1000)
    reads.clear()
    chunked = dec.decimate(read, 7, x.size, 500)
    assert max(reads) <= 1000 + whole[2]               # memory bounded by the chunk size
    assert np.array_equal(whole[0], chunked[0]) and np.array_equal(whole[1], chunked[1])


def test_a_spike_between_stride_samples_survives():
    x = np.zeros(100_000)
    x[12_345] = 7.0                                    # one-sample spike
    idx, vals, _ = dec.decimate(lambda a, b: x[a:b], 0, x.size, 200)
    assert 12_345 in idx and vals.max() == 7.0
