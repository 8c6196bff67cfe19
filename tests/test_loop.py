"""Hysteresis-loop quantities per cycle against closed forms (seed 002 Eq. 1, Fig. 2)."""

import numpy as np
import pytest

from labjoint.identify.loop import cycle_metrics, loop_area, loop_metrics
from labjoint.signal.cycles import cycles

F0 = 400.0
OMEGA = 2 * np.pi * F0


def _phase(m, n_cycles=1):
    return 2 * np.pi * np.arange(n_cycles * m) / m


def jenkins(u, k, f_s):
    """Exact Jenkins element (spring k in series with a Coulomb slider f_s), from rest."""
    z, out = 0.0, np.empty_like(u)
    for i, ui in enumerate(u):
        trial = k * (ui - z)
        if trial > f_s:
            z = ui - f_s / k
        elif trial < -f_s:
            z = ui + f_s / k
        out[i] = k * (ui - z)
    return out


def test_viscous_ellipse_area_and_damping():
    U, k, c, m = 7e-6, 1.1e7, 1800.0, 256
    s = _phase(m, 3)
    u = U * np.sin(s)
    F = k * u + c * U * OMEGA * np.cos(s)
    r = cycle_metrics(u.reshape(3, m), F.reshape(3, m), F0)
    bias = m * np.sin(2 * np.pi / m) / (2 * np.pi)       # trapezoid of an M-gon
    assert r["energy_loss"] == pytest.approx(np.pi * c * OMEGA * U ** 2 * bias, rel=1e-9)
    assert r["damping"] == pytest.approx(c, rel=3e-4)                       # Eq. 1
    assert r["damping_fundamental"] == pytest.approx(c, rel=2e-4)
    assert r["stiffness_lsq"] == pytest.approx(k, rel=1e-9)
    assert r["stiffness_secant"] == pytest.approx(np.hypot(k, c * OMEGA), rel=3e-4)
    assert r["displacement_amplitude"] == pytest.approx(U, rel=1e-4)


def test_jenkins_element_loses_4_fs_times_u_minus_fs_over_k_per_cycle():
    U, k, f_s, m = 10e-6, 1.2e7, 60.0, 2048
    s = _phase(m, 3)
    u = U * np.sin(s)
    F = jenkins(u, k, f_s)
    cyc_u, cyc_f = u[m:].reshape(2, m), F[m:].reshape(2, m)        # after virgin loading
    r = cycle_metrics(cyc_u, cyc_f, F0)
    assert r["energy_loss"] == pytest.approx(4 * f_s * (U - f_s / k), rel=1e-4)
    assert r["stiffness_secant"] == pytest.approx(f_s / U, rel=1e-4)        # loop tips
    assert r["force_amplitude"] == pytest.approx(f_s, rel=1e-9)


def test_jenkins_below_slip_is_a_lossless_spring():
    U, k, f_s, m = 3e-6, 1.2e7, 60.0, 512
    u = U * np.sin(_phase(m, 2))
    r = cycle_metrics(u.reshape(2, m), jenkins(u, k, f_s).reshape(2, m), F0)
    assert np.all(np.abs(r["energy_loss"]) < 1e-12 * k * U ** 2)
    assert r["stiffness_lsq"] == pytest.approx(k, rel=1e-9)


def test_linear_spring_zero_loss_and_both_stiffness_estimators_give_k():
    U, k, m = 5e-6, 9e6, 300
    s = _phase(m, 2) + 0.3
    u = U * (np.sin(s) + 0.2 * np.sin(3 * s))              # any periodic motion
    r = cycle_metrics(u.reshape(2, m), (k * u).reshape(2, m), F0)
    assert np.all(np.abs(r["energy_loss"]) < 1e-12 * k * U ** 2)
    assert r["stiffness_lsq"] == pytest.approx(k, rel=1e-12)
    assert r["stiffness_secant"] == pytest.approx(k, rel=1e-12)


def test_loop_area_sign_orientation_and_offset_invariance():
    s = _phase(400)
    u, F = np.cos(s), -np.sin(s)                            # force leads: dissipative
    w = loop_area(u, F)
    assert w > 0
    assert loop_area(u[::-1], F[::-1]) == pytest.approx(-w)
    assert loop_area(u + 3.0, F - 7.0) == pytest.approx(w, rel=1e-12)
    assert loop_area(np.roll(u, 37), np.roll(F, 37)) == pytest.approx(w, rel=1e-12)


def test_open_loop_is_closed_by_the_segment_back_to_the_start():
    # half an ellipse, open: the closing chord makes the area that of the half-disc
    s = np.linspace(0, np.pi, 2001)
    assert loop_area(np.cos(s), -np.sin(s)) == pytest.approx(np.pi / 2, rel=1e-6)


def test_fused_per_cycle_kernel_equals_resample_then_metrics():
    rng = np.random.default_rng(2)
    t = np.arange(20_000) / 50_000.0
    u = 6e-6 * np.sin(OMEGA * t + 0.3) + 2e-4 + 5e-8 * rng.standard_normal(t.size)
    F = jenkins(u - 2e-4, 1.2e7, 40.0) + 900.0 * np.gradient(u, t) + 3.0
    bounds = 2.5 + np.arange(150) * 125.0 + 0.01 * rng.standard_normal(150)
    ref = cycle_metrics(*cycles(np.stack([u, F]), bounds, 200), F0, n_harmonics=4)
    offset = 1000
    part = slice(offset, None)
    b = bounds[bounds > offset + 1]
    got = loop_metrics(u[part], F[part], b, F0, 200, 4, offset=offset)
    first = np.flatnonzero(bounds > offset + 1)[0]
    for name, value in got.items():
        expected = ref[name][first:first + value.shape[0]]
        assert np.allclose(value, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max()), name
