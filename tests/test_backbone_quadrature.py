"""The phase-resonance point's quadrature correction at the recorded amplitude
(labjoint.identify.backbone.quadrature_at_amplitude) on closed forms and an independent
time integration written here."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from labjoint.identify.backbone import quadrature_at_amplitude


def test_a_linear_oscillator_off_quadrature_gives_its_natural_frequency_and_damping():
    m, k, zeta = 3.9, 1.25e5, 0.011
    wn = math.sqrt(k / m)
    c = 2 * zeta * m * wn
    for w in (0.995 * wn, 0.9995 * wn, 1.004 * wn):          # a few degrees either side
        X = 2.0 / (k - m * w * w + 1j * c * w)                  # displacement per 2 N, closed form
        e = float(np.angle(X)) + math.pi / 2
        fr, sd, z = quadrature_at_amplitude(w, 2.0, abs(X), e, m, 1e-4, 0.0)
        assert fr == pytest.approx(wn / (2 * np.pi), rel=1e-12)
        assert z == pytest.approx(zeta, rel=1e-12)
        assert sd > 0
    # the mass's uncertainty acts on the correction only: none at quadrature
    X = 2.0 / (1j * c * wn)
    assert quadrature_at_amplitude(wn, 2.0, abs(X), 0.0, m, 0.0, 0.01)[1] == pytest.approx(0.0, abs=1e-12)


def test_a_hardening_oscillator_driven_off_its_backbone_lands_on_it_at_the_recorded_amplitude():
    """Duffing, m x'' + c x' + k x + k3 x^3 = F cos(w t), integrated to steady state by
    solve_ivp: the backbone at amplitude A is w_n(A)^2 = (k + 3/4 k3 A^2) / m (first
    harmonic). Driven 0.3 % below it at constant force, the response is off quadrature and
    its amplitude differs from the amplitude at the force's own phase resonance: the
    correction must land on the backbone at the amplitude recorded, as a slope at
    constant drive (the plan's) does not."""
    m, k, c, k3, F = 1.0, (2 * np.pi * 10) ** 2, 2 * 0.01 * 2 * np.pi * 10, 3e4, 4.0
    A_guess = F / (c * 2 * np.pi * 10)
    w = 0.997 * math.sqrt((k + 0.75 * k3 * A_guess ** 2) / m)
    T = 2 * np.pi / w
    sol = solve_ivp(lambda t, y: [y[1], (F * np.cos(w * t) - c * y[1] - k * y[0] - k3 * y[0] ** 3) / m],
                    (0, 240 * T), [0.0, 0.0], method="DOP853", rtol=1e-10, atol=1e-12, dense_output=True)
    t = np.linspace(200 * T, 240 * T, 40 * 256, endpoint=False)
    X1 = 2 * np.mean(sol.sol(t)[0] * np.exp(-1j * w * t))        # fundamental phasor, force real
    A, e = abs(X1), float(np.angle(X1)) + math.pi / 2
    assert abs(e) > math.radians(3)                               # well off quadrature
    fr, _, z = quadrature_at_amplitude(w, F, A, e, m, 0.0, 0.0)
    wn = math.sqrt((k + 0.75 * k3 * A * A) / m)
    assert 2 * np.pi * fr == pytest.approx(wn, rel=2e-5)
    assert z == pytest.approx(c / (2 * m * wn), rel=1e-3)
    # a correction e / S with the linear slope at the drive's damping misses by far more
    assert abs(w + e * (2 * c / (2 * m)) - wn) > 20 * abs(2 * np.pi * fr - wn)


def test_a_level_far_off_quadrature_is_refused():
    from labjoint.errors import InputError
    with pytest.raises(InputError, match="did not lock"):
        quadrature_at_amplitude(10.0, 5.0, 1e-3, -math.pi / 2, 1.0, 0.0, 0.0)
