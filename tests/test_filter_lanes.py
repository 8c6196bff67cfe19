"""The zero-phase filter's lanes (three sections written out per group, identity
sections completing the last group): scipy's sosfiltfilt bit for bit on whole rows for
every order, and to 1e-12 relative when rows are cut into overlapping pieces or streamed
in blocks (the analyze pipeline's path)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from labjoint.signal.filter import ZeroPhaseStream, butter_sos, settling_samples
from labjoint.signal.lanes import filtfilt_pieces

FS = 50_000.0


@pytest.mark.parametrize("order", range(1, 13))
def test_whole_rows_are_scipys_sosfiltfilt_bit_for_bit_at_every_order(order):
    sos = butter_sos(FS, 3000.0, order)
    x = np.random.default_rng(order).standard_normal((3, 4_000)).cumsum(axis=1)
    got, _ = filtfilt_pieces(sos, x)
    assert np.array_equal(got, sps.sosfiltfilt(sos, x, axis=-1))


@pytest.mark.parametrize("rows, pieces, keep", [(1, 16, None), (2, 8, (300, 99_000)),
                                                (3, 5, (0, 1_000))])
def test_pieces_in_sixteen_lanes_equal_the_whole_row_to_1e_12(rows, pieces, keep):
    sos = butter_sos(FS)
    rng = np.random.default_rng(rows)
    x = rng.standard_normal((rows, 100_000)).cumsum(axis=1) + rng.standard_normal((rows, 100_000))
    whole = sps.sosfiltfilt(sos, x, axis=-1)
    lo, hi = keep if keep is not None else (0, x.shape[1])
    got, work = filtfilt_pieces(sos, x, pieces, settling_samples(sos), keep=keep)
    assert work.shape[1] == rows * pieces and got.shape == (rows, hi - lo)
    scale = np.max(np.abs(whole), axis=1, keepdims=True)
    assert np.max(np.abs(got - whole[:, lo:hi]) / scale) < 1e-12


def test_a_stream_of_uneven_blocks_equals_scipy_on_the_whole_record_to_1e_12():
    rng = np.random.default_rng(7)
    n = 400_000
    x = 1e-5 * np.sin(2 * np.pi * 400.0 * np.arange(n) / FS) + 1e-7 * rng.standard_normal((2, n))
    stream = ZeroPhaseStream(FS)
    parts, i = [], 0
    while i < n:
        step = int(rng.integers(1_000, 150_000))
        parts.append(stream.push(x[:, i:i + step]))
        i += step
    parts.append(stream.finish())
    got = np.concatenate(parts, axis=1)
    whole = sps.sosfiltfilt(butter_sos(FS), x, axis=-1)
    assert got.shape == whole.shape
    assert np.max(np.abs(got - whole)) < 1e-12 * np.max(np.abs(whole))
