"""A ringdown window's stated sd covers its true error (labjoint.signal.ringdown_scatter).

Independent generator, written here: x = a(t) cos(phi(t)) with a = exp(-sigma t) and a
softening phase phi' = w0 (1 - c a^2) (closed form), plus white noise and, in the second
case, a weak constant tone at 0.85 f0 that beats with the decay (an error smooth inside
one window, which the window's least-squares sd does not see: with it, |error| / sd of
the least-squares sd alone has an rms of 7.6 in frequency and 6.8 in damping on these
records; without it 1.46 and 1.48). The truth at a point is the generator's
w_n = hypot(w0 (1 - c a^2), sigma) and zeta = sigma / w_n at the point's own amplitude.
"""

import math

import numpy as np
import pytest

from labjoint.signal.ringdown import ringdown_backbone
from labjoint.signal.ringdown_scatter import honest_sds, local_scatter, trend_residuals

F0, FS, T, ZETA, C = 30.0, 1000.0, 10.0, 0.004, 0.005
W0 = 2 * math.pi * F0
SIG = ZETA * W0


def decay(seed: int, tone: float, noise: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(int(T * FS)) / FS
    phi = W0 * t - W0 * C * (1 - np.exp(-2 * SIG * t)) / (2 * SIG)
    return (np.exp(-SIG * t) * np.cos(phi) + tone * np.cos(0.85 * W0 * t + rng.uniform(0, 2 * math.pi))
            + noise * rng.standard_normal(t.size))


def normalised_errors(tone: float, noise: float, seeds=range(4)):
    zf, zz = [], []
    for seed in seeds:
        bb = ringdown_backbone(decay(seed, tone, noise), FS, noise_rms=noise)
        for p in bb.points:
            wn = math.hypot(W0 * (1 - C * p.amplitude ** 2), SIG)
            zf.append((p.frequency_hz - wn / (2 * math.pi)) / p.frequency_sd_hz)
            zz.append((p.damping_ratio - SIG / wn) / p.damping_sd)
    return np.array(zf), np.array(zz)


def rms(v) -> float:
    return float(np.sqrt(np.mean(np.square(v))))


@pytest.mark.parametrize("tone", [0.0, 3e-3])
def test_stated_sd_covers_the_true_error_of_both_methods(tone):
    zf, zz = normalised_errors(tone, 1e-3)
    assert zf.size > 300
    # at the stated rate: rms of |error| / sd near 1 (0.96 / 0.96 without the tone,
    # 0.81 / 0.77 with it), not several
    assert 0.6 < rms(zf) < 1.3 and 0.6 < rms(zz) < 1.3, (rms(zf), rms(zz))
    # and the tails are a normal's, not a few windows far out
    assert np.mean(np.abs(zf) > 3) < 0.02 and np.mean(np.abs(zz) > 3) < 0.02


def test_trend_residual_of_one_bad_value_on_a_smooth_curve():
    """On a quadratic (any local trend of degree <= 2 is followed exactly) the residuals
    are zero except at a value moved by d, where it is d / sqrt(1 + h); h for 3
    neighbours each side (-3..3 without 0) under a quadratic is 0.5 (closed form:
    x0' (X'X)^-1 x0 with sum j^2 = 28, sum j^4 = 196: 196 / (6 196 - 28^2) = 0.5)."""
    i = np.arange(15.0)
    v = 2.0 + 0.3 * i - 0.01 * i ** 2
    assert np.allclose(trend_residuals(v), 0.0, atol=1e-12)
    v[7] += 1.0
    e = trend_residuals(v)
    assert e[7] == pytest.approx(1 / math.sqrt(1.5))
    # the bad value's neighbours see it too (their trend is spoilt), so the local
    # scatter is raised around it and the window's own least-squares sd is replaced there
    sd = honest_sds(v, np.full(15, 1e-3))
    assert sd[7] > 0.3 and sd[0] == pytest.approx(1e-3) and sd[14] == pytest.approx(1e-3)


def test_white_values_scatter_estimates_their_sd():
    rng = np.random.default_rng(1)
    s = 0.2
    v = np.linspace(0, 5, 4000) + s * rng.standard_normal(4000)
    assert np.median(local_scatter(v)) == pytest.approx(s, rel=0.1)
    assert rms(trend_residuals(v)) == pytest.approx(s, rel=0.05)
