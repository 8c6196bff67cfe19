"""Stick-slip-boundary pipeline (seed 002 Eqs. 2-9): closed forms, invariants, errors."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from labjoint.errors import InputError
from labjoint.identify.contact import (CONTACT_RATIO, PRESSURE_COEFFICIENTS, X_ZERO,
                                       ContactPressure, pressure_ratio)
from labjoint.identify.quarters import rising_quarters
from labjoint.identify.stickslip import stick_slip_curves

RB = 4e-3
N = 5 * 478.0
MU = 0.168
KT = 5.9e6
F = 400.0


def _cp(**kw):
    return ContactPressure(bolt_radius_m=RB, normal_force_n=N, **kw)


def _run(u, starts=None, **kw):
    args = dict(shear_stiffness_n_per_m=KT, friction_coefficient=MU, contact=_cp(), frequency_hz=F)
    args.update(kw)
    return stick_slip_curves(u, starts, **args)


# ---- Eq. 2 pressure law -------------------------------------------------------------

def test_pressure_alternating_signs_vanish_at_contact_boundary():
    assert pressure_ratio(0.0) == pytest.approx(PRESSURE_COEFFICIENTS[0])
    assert abs(X_ZERO - CONTACT_RATIO) < 1e-3
    x = np.linspace(0, X_ZERO, 500, endpoint=False)
    p = pressure_ratio(x)
    assert np.all(p > 0) and np.all(np.diff(p) < 0)
    assert pressure_ratio(3.6) == 0.0


def test_capacity_closed_form_matches_quadrature():
    cp = _cp()
    for c in [0.0, RB, 1.7 * RB, 2.5 * RB, 3.3 * RB]:
        ref, _ = quad(lambda r: float(cp.pressure(r)) * 2 * np.pi * r, c, X_ZERO * RB,
                      epsabs=0, epsrel=1e-12, limit=200)
        assert float(cp.capacity(c)) == pytest.approx(ref, rel=1e-9)


def test_sigma_s_normalised_to_normal_force_or_literal_head_stress():
    cp = _cp(head_radius_m=2 * RB, inner_radius_m=RB)        # hole excluded
    assert cp.total_force == pytest.approx(N, rel=1e-12)
    lit = _cp(head_radius_m=2 * RB, inner_radius_m=RB, sigma_s_mode="head")
    assert lit.sigma_s == pytest.approx(N / (np.pi * ((2 * RB) ** 2 - RB ** 2)))
    assert lit.total_force / N == pytest.approx(cp.force_ratio, rel=1e-12)
    # integrated pressure from the hole edge r_b to 3.5 r_b is 2.41 pi r_b^2 sigma_s
    assert cp.force_ratio == pytest.approx(2.4073 / 3.0, rel=1e-3)
    full = _cp()                                               # full disc 0..a
    assert full.sigma_s == pytest.approx(N / (np.pi * RB ** 2 * 3.04445), rel=1e-4)


def test_radius_for_load_inverts_capacity_and_flags_macro_slip():
    cp = _cp()
    rng = np.random.default_rng(1)
    loads = np.concatenate([rng.uniform(0, N, 40), [1e-9, 1e-4, N * (1 - 1e-9)]])
    c, over = cp.radius_for_load(loads)
    assert not over.any()
    for L, ci in zip(loads, c):
        ref = brentq(lambda r: float(cp.capacity(r)) - L, cp.inner, X_ZERO * RB, xtol=1e-16)
        assert ci == pytest.approx(ref, rel=1e-9, abs=1e-13)
    c, over = cp.radius_for_load(np.array([0.0, -1.0, 1.01 * N]))
    assert list(over) == [False, False, True]
    assert c[0] == cp.a and c[1] == cp.a and c[2] == pytest.approx(cp.inner)


# ---- Eqs. 6-9 -----------------------------------------------------------------------

def test_boundary_falls_monotonically_and_energy_is_nonnegative():
    u = 7.4e-6 * np.sin(np.linspace(0, np.pi / 2, 200))
    q = _run(u)
    assert q.boundary_radius_m[0] == pytest.approx(_cp().a)
    assert np.all(np.diff(q.boundary_radius_m) < 0)
    assert np.all(q.boundary_radius_m >= _cp().inner)
    assert np.all(q.energy_loss_j >= 0) and np.all(np.diff(q.energy_loss_j) >= 0)
    assert q.energy_loss_j[0] == 0.0 and q.damping_ns_per_m[0] == 0.0   # no damping at u = 0
    assert not q.macro_slip.any()
    # Eq. 6 holds at every sample: mu * capacity(c_i) = K_t u_i
    assert np.allclose(q.sliding_force_n, KT * u, rtol=1e-9, atol=1e-9)
    assert np.allclose(q.stiffness_n_per_m, 2 * KT)                    # Eq. 9


def test_energy_and_damping_converge_to_closed_form():
    U = 5e-6
    u = U * np.sin(np.linspace(0, np.pi / 2, 20001))
    q = _run(u)
    W = q.energy_loss_j[-1]
    assert W == pytest.approx(2 * KT * U ** 2, rel=2e-4)               # 4 K_t int u du
    assert q.damping_ns_per_m[-1] == pytest.approx(2 * KT / (np.pi * 2 * np.pi * F), rel=2e-4)


def test_seed_table2_is_the_right_endpoint_sum_of_the_exact_model():
    # 400 Hz, K = 11.8 MN/m (Table 2), U from W_loop and C_loop via Eq. 1. The model's
    # exact values are W = 2 K_t U^2 and C = K / (pi omega); the paper's 0.672 mJ and
    # 1542 Ns/m are its right-endpoint sum, 1 + (pi/4)(2 pi f / fs) times larger.
    U = np.sqrt(0.809e-3 / (np.pi * 2 * np.pi * F * 1867))
    K, omega = 11.8e6, 2 * np.pi * F
    t = np.arange(0, 0.25 / F + 1e-12, 1 / 50e3)
    q = _run(U * np.sin(2 * np.pi * F * t), shear_stiffness_n_per_m=K / 2)
    assert q.energy_loss_j[-1] == pytest.approx(K * q.displacement_m[-1] ** 2, rel=1e-9)
    assert q.damping_ns_per_m[-1] == pytest.approx(K / (np.pi * omega), rel=1e-6)
    assert 1542 / (K / (np.pi * omega)) == pytest.approx(1.031, abs=0.001)   # the tables' factor


def right_endpoint_factor(samples_per_cycle: float) -> float:
    """The paper's sum over a quarter sine, relative to the integral (derived, not fitted):
    (2/U^2) sum_i u_i (u_i - u_{i-1}) = 1 + (2/U^2) (1/2) sum du^2 ~ 1 + (pi/4) dtheta."""
    th = np.arange(0, np.pi / 2 + 1e-12, 2 * np.pi / samples_per_cycle)
    s = np.sin(th)
    return float(2 * np.sum(s[1:] * np.diff(s)) / s[-1] ** 2)


@pytest.mark.parametrize("spc", [20, 50, 125, 500])
def test_w_and_c_do_not_depend_on_the_sample_rate(spc):
    # before: the right-endpoint sum made W and C grow by (pi/4)(2 pi / spc): 4 % at 20
    U, omega = 6e-6, 2 * np.pi * F
    th = np.arange(0, np.pi / 2 + 1e-12, 2 * np.pi / spc)
    th[-1] = np.pi / 2
    q = _run(U * np.sin(th))
    assert q.energy_loss_j[-1] == pytest.approx(2 * KT * U ** 2, rel=1e-3)
    assert q.damping_ns_per_m[-1] == pytest.approx(2 * KT / (np.pi * omega), rel=1e-3)
    assert right_endpoint_factor(spc) == pytest.approx(1 + np.pi / 4 * 2 * np.pi / spc, rel=0.02)


def test_full_macro_slip_counts_friction_once():
    # u* = f_max / K_t far below the first step: every sample slides (100 % macro-slip).
    # By hand (Eqs. 3, 7-9): F = f_max, K = f_max / U, W = 2 K_t u*^2 + 4 f_max (U - u*),
    # C = W / (pi omega U^2). Before: K = (f_max + f_max) / U and the summary said 2 K_t.
    mu = 1e-3                                       # the smallest coefficient taken
    f_max = mu * N
    u_star = f_max / KT
    U = 8e-5
    u = U * np.sin(np.linspace(0, np.pi / 2, 200))
    q = _run(u, friction_coefficient=mu)
    assert u_star < u[1] and q.macro_slip[1:].all()
    W = 2 * KT * u_star ** 2 + 4 * f_max * (U - u_star)
    assert q.energy_loss_j[-1] == pytest.approx(W, rel=1e-9)
    assert q.stiffness_n_per_m[-1] == pytest.approx(f_max / U, rel=1e-9)
    assert q.damping_ns_per_m[-1] == pytest.approx(W / (np.pi * 2 * np.pi * F * U ** 2), rel=1e-9)


def test_macro_slip_clamps_boundary_and_dissipates_coulomb_energy():
    u_star = MU * N / KT
    U = 3 * u_star
    u = np.linspace(0, U, 30001)
    q = _run(u)
    beyond = u > u_star * (1 + 1e-6)
    within = u < u_star * (1 - 1e-6)
    assert q.macro_slip[beyond].all() and not q.macro_slip[within].any()
    assert np.allclose(q.boundary_radius_m[beyond], _cp().inner)
    expected = 2 * KT * u_star ** 2 + 4 * MU * N * (U - u_star)
    assert q.energy_loss_j[-1] == pytest.approx(expected, rel=1e-3)
    assert q.totals()["macro_slip"].tolist() == [True]


def test_flat_quarters_match_single_quarters():
    a = 3e-6 * np.sin(np.linspace(0, np.pi / 2, 40))
    b = 9e-6 * np.sin(np.linspace(0, np.pi / 2, 33))
    q = _run(np.concatenate([a, b]), np.array([0, a.size]))
    qa, qb = _run(a), _run(b)
    assert np.allclose(q.quarter(0)["energy_loss_j"], qa.energy_loss_j)
    assert np.allclose(q.quarter(1)["energy_loss_j"], qb.energy_loss_j)
    assert np.allclose(q.totals()["damping_ns_per_m"], [qa.damping_ns_per_m[-1], qb.damping_ns_per_m[-1]])


def test_rising_quarters_cut_at_zero_crossing_and_maximum():
    fs, U = 50e3, 4e-6
    t = np.arange(int(0.1 * fs)) / fs
    rng = np.random.default_rng(0)
    u = U * np.sin(2 * np.pi * F * t + 1.0) + 1e-6 + 2e-9 * rng.standard_normal(t.size)
    qs = rising_quarters(u, fs, F)
    n_q = qs.starts.size
    assert 38 <= n_q <= 40                         # 40 cycles, ends may be cut
    assert np.all(qs.displacement_m[qs.starts] == 0.0)
    ends = np.append(qs.starts[1:], qs.displacement_m.size) - 1
    assert np.allclose(qs.displacement_m[ends], U, rtol=0.01)
    lengths = np.diff(np.append(qs.starts, qs.displacement_m.size))
    assert np.all(np.abs(lengths - (fs / F / 4 + 1)) <= 2)


# ---- bad parameters -------------------------------------------------------------------

@pytest.mark.parametrize("kw, field", [
    (dict(bolt_radius_m=-1e-3), "bolt_radius_m"),
    (dict(contact_radius_m=RB), "contact_radius_m"),
    (dict(contact_radius_m=0.5 * RB), "contact_radius_m"),
    (dict(normal_force_n=0.0), "normal_force_n"),
    (dict(inner_radius_m=-1e-3), "inner_radius_m"),
    (dict(sigma_s_mode="head"), "head_radius_m"),
])
def test_bad_contact_parameters_raise_named_input_error(kw, field):
    args = dict(bolt_radius_m=RB, normal_force_n=N)
    args.update(kw)
    with pytest.raises(InputError) as exc:
        ContactPressure(**args)
    assert exc.value.field == field and field in str(exc.value)


@pytest.mark.parametrize("kw, field", [
    (dict(friction_coefficient=0.0), "friction_coefficient"),
    (dict(friction_coefficient=-0.1), "friction_coefficient"),
    (dict(shear_stiffness_n_per_m=0.0), "shear_stiffness_n_per_m"),
    (dict(frequency_hz=0.0), "frequency_hz"),
])
def test_bad_method_parameters_raise_named_input_error(kw, field):
    with pytest.raises(InputError) as exc:
        _run(np.linspace(0, 1e-6, 10), **kw)
    assert exc.value.field == field


def test_run_level_bad_inputs_name_the_parameter():
    from labjoint.identify.methods import analyze_one
    from labjoint.identify.stickslip import StickSlipIdentifier
    from labjoint.storage.run import Run

    fs = 50e3
    t = np.arange(5000) / fs
    u = 3e-6 * np.sin(2 * np.pi * F * t)
    for md, field in (({"torque_nm": 0.0}, "torque_nm"), ({}, "torque_nm"),
                      ({"torque_nm": 5.0, "bolt_radius_m": -4e-3}, "bolt_radius_m"),
                      ({"torque_nm": 5.0, "contact_radius_m": 3e-3, "bolt_radius_m": 4e-3},
                       "contact_radius_m")):
        with pytest.raises(InputError) as exc:
            StickSlipIdentifier(MU, KT).fit_arrays(u, None, fs, F, metadata=md)
        assert exc.value.field == field
    with pytest.raises(InputError) as exc:
        StickSlipIdentifier(0.0, KT).fit_arrays(u, None, fs, F, metadata={"torque_nm": 5.0})
    assert exc.value.field == "friction_coefficient"
    with pytest.raises(InputError) as exc:
        StickSlipIdentifier(MU).fit_arrays(u, None, fs, F, metadata={"torque_nm": 5.0})
    assert exc.value.field == "shear_stiffness"            # K_t needs the force record
    run = Run("r", t, u, KT * 2 * u, {"torque_nm": 5.0, "sample_rate_hz": fs, "frequency_hz": F})
    with pytest.raises(InputError) as exc:
        analyze_one(run, "fem", friction=MU)
    assert exc.value.field == "method"


def test_run_level_pipeline_on_a_linear_spring_gives_closed_form():
    from labjoint.identify.stickslip import StickSlipIdentifier

    fs, U = 50e3, 5e-6
    t = np.arange(int(0.2 * fs)) / fs
    u = U * np.sin(2 * np.pi * F * t)
    est = StickSlipIdentifier(MU).fit_arrays(u, 2 * KT * u, fs, F, name="lin",
                                             metadata={"torque_nm": 5.0})
    s = est.result_.summary
    assert est.result_.shear_stiffness.value == pytest.approx(KT, rel=1e-4)   # K = 2 K_t
    assert s["displacement_amplitude_m"] == pytest.approx(U, rel=1e-3)
    # Eq. 7 integrated exactly: 2 K_t U^2 at any sampling; C = K / (pi omega)
    assert s["energy_loss_j"] == pytest.approx(2 * KT * U ** 2, rel=2e-3)
    assert s["damping_ns_per_m"] == pytest.approx(2 * KT / (np.pi * 2 * np.pi * F), rel=2e-3)
    assert s["stiffness_n_per_m"] == pytest.approx(2 * KT, rel=1e-9)
    assert s["basis"].startswith("model-based")
    assert s["cycles"] >= 70 and s["macro_slip_fraction"] == 0.0
