"""The streamed loop pipeline holds a bounded amount of memory at any sample rate."""

import tracemalloc

import numpy as np
import pytest

from labjoint.identify.analyze import analyze_blocks

F0, U, K, C = 400.0, 5e-6, 1.0e7, 800.0


def _blocks(fs: float, n: int, block: int = 1 << 17):
    """A viscous joint's (displacement, force) record, generated block by block."""
    w = 2 * np.pi * F0
    for a in range(0, n, block):
        t = np.arange(a, min(a + block, n)) / fs
        u = U * np.sin(w * t)
        yield np.stack([u, K * u + C * U * w * np.cos(w * t)])


def _peak_bytes(fs: float, n: int) -> tuple[int, object]:
    tracemalloc.start()
    try:
        res = analyze_blocks(_blocks(fs, n), fs, F0)
        return tracemalloc.get_traced_memory()[1], res
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("fs", [1.25e6, 2e6])
def test_memory_does_not_grow_with_the_record_at_megasample_rates(fs):
    # Before: the filter's settling search doubled forever at >= 1.25 MS/s (> 20 GB).
    short, _ = _peak_bytes(fs, 1 << 20)
    long_, res = _peak_bytes(fs, 1 << 22)                 # 4x the samples
    assert long_ < 1.25 * short + (4 << 20)               # constant, not proportional
    assert long_ < 200e6
    s = res.summary                                       # and the numbers are right
    assert s["damping_ns_per_m"] == pytest.approx(C, rel=1e-3)
    assert s["stiffness_n_per_m"] == pytest.approx(K, rel=1e-4)
