"""The streamed pipeline (filter in lanes and pieces, segmenter, loop kernel, in threads)
gives what an independent whole-record computation gives: scipy's sosfiltfilt of the
whole record, the cycles cut there, the loop quantities of those cycles: equal to 1e-12
relative (the loop's fundamentals to 3e-12: see below; issue 31 item 4: speed without
giving up exactness)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from labjoint.identify.analyze import analyze_arrays
from labjoint.identify.loop import loop_metrics
from labjoint.signal.filter import butter_sos
from labjoint.signal.phase import segment_cycles

FS, F0 = 50_000.0, 400.0


def _record(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A Jenkins element (stiffness 3 MN/m, slip 4 um) beside 2 MN/m and 500 Ns/m, from
    rest: the loop has an area and harmonics; noise on both channels."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    env = 1.0 - np.exp(-t / 0.02)
    u = 1e-5 * env * np.sin(2 * np.pi * F0 * t)
    z, slip, friction = 0.0, 4e-6, np.empty(n)
    for i, ui in enumerate(u):                 # the slider's position follows the stop
        z = min(max(z, ui - slip), ui + slip)
        friction[i] = 3e6 * (ui - z)
    v = 1e-5 * env * 2 * np.pi * F0 * np.cos(2 * np.pi * F0 * t)
    F = friction + 2e6 * u + 500.0 * v
    return u + 3e-9 * rng.standard_normal(n), F + 0.05 * rng.standard_normal(n)


@pytest.mark.parametrize("threads", [True, False])
def test_streamed_analysis_equals_scipy_on_the_whole_record(threads):
    u, F = _record(700_000, 3)
    res = analyze_arrays(u, F, FS, F0, threads=threads)
    y = sps.sosfiltfilt(butter_sos(FS), np.stack([u - u.mean(), F - F.mean()]), axis=-1)
    whole_bounds = segment_cycles(y[0], FS, F0)[:res.bounds.size]
    assert res.bounds.size > 5000
    assert np.max(np.abs(res.bounds - whole_bounds)) < 1e-8        # samples, at ~7e5
    ref = loop_metrics(y[0], y[1], res.bounds, F0, 256, 5)
    for key in ("energy_loss", "displacement_amplitude", "force_amplitude", "stiffness_lsq"):
        got, want = getattr(res, key), ref[key]
        assert np.max(np.abs(got - want)) <= 1e-12 * np.max(np.abs(want)), key
    # the stream's joins hold to 1e-12 of the signal's scale (settling_samples' rtol); a
    # Fourier coefficient adds 256 samples' errors with weights 2/256 (seen: 1.06e-12)
    for key in ("displacement_harmonics", "force_harmonics"):
        got, want = getattr(res, key)[:, 0], ref[key][:, 0]
        assert np.max(np.abs(got - want)) <= 3e-12 * np.max(np.abs(want)), key
    assert res.summary["energy_loss_j"] > 0
