"""The local rational method (labjoint/signal/lrm.py) on a lightly damped resonance
written here as a difference equation (scipy lfilter), its block cut out of a longer
response while the mode rings: the FRF exact without noise, the transient removed, the
std the actual scatter under output noise, the answer the same fitted in chunks."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from labjoint.signal import lrm

FS, F_N, ZETA = 256.0, 20.0, 0.005


def _system():
    """A resonance at 20 Hz, 0.5 % damping, discretised (bilinear): b, a of H(z)."""
    w = 2 * np.pi * F_N
    return sps.bilinear([w * w], [1.0, 2 * ZETA * w, w * w], fs=FS)


def _cut(noise: float, seed: int = 0, n: int = 4096):
    b, a = _system()
    rng = np.random.default_rng(seed)
    u = rng.normal(size=3 * n)
    y = sps.lfilter(b, a, u)
    u, y = u[n:2 * n], y[n:2 * n] + noise * rng.normal(size=n)   # cut mid-stream
    U, Y = np.fft.rfft(u)[1:], np.fft.rfft(y)[1:]
    f = np.fft.rfftfreq(n, 1 / FS)[1:]
    _, want = sps.freqz(b, a, worN=f, fs=FS)
    keep = f < 100.0                  # the bilinear map's zero at Nyquist: no relative error
    return U[keep], Y[keep], want[keep]


def test_exact_without_noise_where_the_plain_ratio_leaks():
    U, Y, want = _cut(0.0)
    h, _ = lrm.local_rational(U, Y[None])
    assert np.max(np.abs(h[0] / want - 1)) < 1e-6
    assert np.median(np.abs(Y / U / want - 1)) > 1e-3        # the transient: leakage


def test_std_is_the_scatter_under_output_noise():
    U, Y, want = _cut(0.05, seed=1)
    h, std = lrm.local_rational(U, Y[None])
    z = (h[0] - want) / std[0]
    assert 0.8 < np.sqrt(np.mean(np.abs(z) ** 2) / 2) < 1.25


def test_chunks_give_the_same_answer(monkeypatch):
    U, Y, _ = _cut(0.01, seed=2)
    whole = lrm.local_rational(U, np.vstack([Y, 2 * Y]))
    monkeypatch.setattr(lrm, "CHUNK_LINES", 100)
    chunked = lrm.local_rational(U, np.vstack([Y, 2 * Y]))
    assert np.allclose(whole[0], chunked[0], rtol=1e-12, atol=0) and np.allclose(whole[1], chunked[1])
    assert np.allclose(whole[0][1], 2 * whole[0][0])


def test_too_few_lines_are_refused():
    with pytest.raises(Exception, match="local rational method needs more than"):
        lrm.local_rational(np.ones(10), np.ones((1, 10)))
