"""Burst-random FRFs of an oscillator integrated here (scipy solve_ivp, not labjoint's
simulator), as the BERT random tests were taken: 1024 Hz, 16 s blocks, 8.3 s of drive, then
the free decay. A linear oscillator is recovered exactly by both burst estimators: the
default (one unwindowed block, burst + decay, Testlab's burst-random H1) and the option
burst="driven" (the driven part alone, the transient at the cut removed by the local
rational method). A softening one (Duffing, k(x) = k0 (1 - beta x^2)) is answered at its
burst's own amplitude by the driven option: by statistical linearisation its stiffness
at response RMS sigma is k0 (1 - 3 beta sigma^2), and the free decay after the burst, at
lower amplitude, rings nearer k0, which the default's block, decay included, mixes into
the level's FRF: it softens less between levels, and the raw ratio of that block, one
average, scatters between lines with the distortion, so its LSCF reads the damping too
low at the higher level."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps
from scipy.integrate import solve_ivp

from labjoint.identify.modes import find_modes
from labjoint.signal.broadband import estimate

FS, N, BURST_S = 1024.0, 1 << 14, 8.3
F0, ZETA = 18.7, 0.004
W0 = 2 * np.pi * F0


def _burst(level: float, beta: float, seed: int = 1) -> tuple[np.ndarray, np.ndarray, float]:
    """(drive, velocity, response RMS over the burst's steady part) of m x'' + c x' +
    k0 (1 - beta x^2) x = u under band-limited random ``u`` (RMS ``level``) for 8.3 s."""
    rng = np.random.default_rng(seed)
    b, a = sps.butter(4, 150.0, fs=FS)
    u = sps.lfilter(b, a, rng.normal(size=N))
    nb = int(BURST_S * FS)
    u[nb:] = 0.0
    u *= level / u[:nb].std()
    t = np.arange(N) / FS

    def rhs(tt: float, s: np.ndarray) -> list[float]:
        x, v = s
        return [v, np.interp(tt, t, u) - 2 * ZETA * W0 * v - W0 ** 2 * (1 - beta * x * x) * x]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, max_step=1 / FS, rtol=1e-7, atol=1e-12)
    x, v = sol.y
    return u, v, float(x[int(2.5 * FS):nb].std())     # after the build-up (~2 time constants)


def _mode1(r) -> tuple[float, float]:
    modes = find_modes(r.freq_hz, r.h, "velocity", ["v"], (5.0, 60.0))
    m = min(modes, key=lambda m: abs(m["frequency_hz"] - F0))
    return m["frequency_hz"], m["damping_ratio"]


def test_a_linear_burst_is_exact_by_both_estimators():
    u, v, _ = _burst(W0 ** 2 * 1e-4, 0.0)
    r = estimate(u, v[None], FS)
    assert "1 burst block(s)" in r.method and "burst=block" in r.method
    f, z = _mode1(r)
    assert f == pytest.approx(F0, rel=5e-4) and z == pytest.approx(ZETA, rel=0.03)
    r = estimate(u, v[None], FS, burst="driven")
    assert "driven part of 1 burst" in r.method
    f, z = _mode1(r)
    assert f == pytest.approx(F0, rel=5e-4) and z == pytest.approx(ZETA, rel=0.03)


@pytest.mark.slow
def test_a_softening_burst_is_answered_at_its_own_amplitude_by_the_driven_option():
    beta, base = 1.6e4, W0 ** 2 * 1e-4
    got, block, want = [], [], []
    for level in (1.0, 1.5):
        u, v, sigma = _burst(level * base, beta)
        want.append(F0 * np.sqrt(1 - 3 * beta * sigma ** 2))
        got.append(_mode1(estimate(u, v[None], FS, burst="driven")))
        block.append(_mode1(estimate(u, v[None], FS)))
    # driven: frequency below f0 by a share of statistical linearisation's shift (first
    # order in beta sigma^2: it overstates a long stationary record's H1 by 20-30 % here),
    # and the softening between the levels in the same proportion
    for (f, _), fw in zip(got, want):
        assert 0.45 < (F0 - f) / (F0 - fw) < 1.0, (f, fw)
    assert 0.5 < (got[0][0] - got[1][0]) / (want[0] - want[1]) < 1.0, (got, want)
    # the damping stays the oscillator's (a random amplitude broadens the peak a little)
    for _, z in got:
        assert 0.9 * ZETA < z < 1.5 * ZETA, got
    # the default (burst + decay as one block) on the same records, as it is (measured:
    # 18.634 / 18.566 Hz, zeta 0.0035 / 0.0019 against 18.632 / 18.520, 0.0043 / 0.0052):
    # softening in the right direction but only 0.3-0.5 of the linearisation's between the
    # levels (the decay rings nearer f0), less than the driven part's; its damping close
    # at the lower level and far too low at the higher one
    soft = (block[0][0] - block[1][0]) / (want[0] - want[1])
    assert 0.3 < soft < 0.5 < (got[0][0] - got[1][0]) / (want[0] - want[1]), (block, want)
    assert F0 - block[0][0] < F0 - block[1][0] < F0 - got[1][0], (block, got)
    assert 0.7 * ZETA < block[0][1] < 1.1 * ZETA, block
    assert block[1][1] < 0.6 * ZETA < got[1][1], (block, got)
