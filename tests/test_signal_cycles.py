"""Cycle segmentation at the fundamental's upward zero crossings; per-cycle arrays."""

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.signal.cycles import cycles, harmonics
from labjoint.signal.phase import CycleSegmenter, segment_cycles

FS, F0 = 50_000.0, 400.0


def _record(n=60_000, phi=0.7, noise=0.0, seed=0):
    t = np.arange(n) / FS
    rng = np.random.default_rng(seed)
    x = (np.sin(2 * np.pi * F0 * t + phi) + 0.3 * np.sin(2 * np.pi * 3 * F0 * t + 0.2)
         + 0.15 * np.sin(2 * np.pi * 2 * F0 * t) + 0.5 + noise * rng.standard_normal(n))
    # upward zero crossings of the fundamental sin(w t + phi): t = (k - phi / 2 pi) / f0
    k = np.arange(1, int(n * F0 / FS) + 1)
    exact = (k - phi / (2 * np.pi)) * FS / F0
    return x, exact[(exact >= 1) & (exact <= n - 3)]


def test_boundaries_at_fundamental_crossings_despite_harmonics_offset():
    x, exact = _record()
    b = segment_cycles(x, FS, F0)
    assert b.size == exact.size
    assert np.max(np.abs(b - exact)) < 1e-3            # samples; 125 per period


def test_boundary_jitter_under_noise_is_a_small_fraction_of_a_sample():
    # white noise of 20 % of the amplitude on every sample (no low-pass): the phase
    # averages ~170 samples, so the timing jitter is ~0.02 rad, i.e. ~0.4 samples rms
    x, exact = _record(noise=0.2)
    b = segment_cycles(x, FS, F0)
    assert b.size == exact.size
    assert np.sqrt(np.mean((b - exact) ** 2)) < 0.6
    assert np.max(np.abs(b - exact)) < 2.5


def test_streaming_segmenter_equals_whole_record():
    x, _ = _record(noise=0.05)
    whole = segment_cycles(x, FS, F0)
    seg = CycleSegmenter(FS, F0)
    rng = np.random.default_rng(1)
    parts, i = [], 0
    while i < x.size:
        n = int(rng.integers(1, 3000))
        parts.append(seg.push(x[i:i + n]))
        i += n
    parts.append(seg.finish())
    got = np.concatenate(parts)
    assert got.shape == whole.shape
    assert np.max(np.abs(got - whole)) < 1e-6


def test_frequency_slightly_off_still_tracks_the_true_fundamental():
    x, exact = _record()
    b = segment_cycles(x, FS, F0 * 1.002)               # metadata 0.2 % off
    assert b.size == exact.size
    assert np.max(np.abs(b - exact)) < 0.05


def test_cycles_resample_one_period_each():
    x, exact = _record(n=20_000)
    b = segment_cycles(x, FS, F0)
    c = cycles(x, b, 200)
    assert c.shape == (b.size - 1, 200)
    s = np.arange(200) / 200
    expected = (np.sin(2 * np.pi * s) + 0.3 * np.sin(2 * np.pi * 3 * s + 0.2 - 3 * 0.7)
                + 0.15 * np.sin(2 * np.pi * 2 * s - 2 * 0.7) + 0.5)
    assert np.max(np.abs(c - expected)) < 1e-4


def test_harmonics_of_resampled_cycles():
    x, _ = _record(n=20_000)
    b = segment_cycles(x, FS, F0)
    h = harmonics(cycles(x, b, 256), 4)
    assert np.allclose(np.abs(h).mean(axis=0), [1.0, 0.15, 0.3, 0.0], atol=1e-4)
    assert np.allclose(np.angle(h[:, 0]), -np.pi / 2, atol=1e-4)   # sin = cos(. - pi/2)


def test_multichannel_cycles_and_offset():
    x, _ = _record(n=20_000)
    b = segment_cycles(x, FS, F0)
    both = cycles(np.stack([x, 2 * x]), b, 64)
    assert both.shape == (2, b.size - 1, 64)
    assert np.allclose(both[1], 2 * both[0])
    part = cycles(x[1000:], b[(b > 1002) & (b < 19_000)], 64, offset=1000)
    assert np.allclose(part, both[0][np.flatnonzero((b > 1002) & (b < 19_000))[:-1]])


@pytest.mark.parametrize("kwargs, field", [
    ({"bounds": np.array([5.0, 3.0])}, "bounds"),
    ({"bounds": np.array([0.0, 100.0])}, "bounds"),
    ({"bounds": np.array([10.0, 999.0])}, "bounds"),
    ({"n_points": 2}, "n_points"),
])
def test_bad_cycles_input(kwargs, field):
    args = {"x": np.zeros(1000), "bounds": np.array([10.0, 110.0]), **kwargs}
    with pytest.raises(InputError, match=field):
        cycles(**args)


def test_segmenting_needs_enough_samples_per_period():
    with pytest.raises(InputError, match="frequency_hz"):
        segment_cycles(np.zeros(1000), 1000.0, 400.0)
    with pytest.raises(InputError, match="'fs'"):
        segment_cycles(np.zeros(1000), -1.0, 400.0)
