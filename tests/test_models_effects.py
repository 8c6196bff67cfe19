"""Each effect against a closed form or an independent reference (models layer)."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.models import Model, ModelInputs
from labjoint.models.effects import REGISTRY
from labjoint.models.effects._population import iwan_population, population_force
from labjoint.models.effects.richard_abbott import RichardAbbott
from labjoint.vocabulary import EFFECTS

FS = 25600.0


def tone(U: float, f: float, cycles: float, fs: float = FS, phase: float = 0.0, offset: float = 0.0):
    n = int(round(cycles * fs / f))
    t = np.arange(n) / fs
    return ModelInputs.from_record(offset + U * np.sin(2 * np.pi * f * t + phase), fs, frequency_hz=f)


def loop_energy(F: np.ndarray, inp: ModelInputs, f: float, skip: int = 1) -> float:
    """Energy per cycle int F du = sum F v dt over whole steady cycles, skipping ``skip``
    (exact to the derivative's accuracy for periodic signals)."""
    per = inp.fs / f
    assert per == int(per), "use a whole number of samples per period"
    a = int(round(skip * per))
    k = int((inp.u.size - a) // per)
    b = a + int(round(k * per))
    return float(np.sum(F[a:b] * inp.v[a:b]) / inp.fs / k)


def harmonics(F: np.ndarray, f: float, fs: float, skip: int = 2) -> np.ndarray:
    """|F_h| for h = 0..4 over whole steady cycles (DFT at multiples of f)."""
    per = fs / f
    assert per == int(per), "use a whole number of samples per period"
    a = int(round(skip * per))
    k = int((F.size - a) // per)
    seg = F[a:a + int(round(k * per))]
    t = np.arange(seg.size) / fs
    out = [abs(np.mean(seg))]
    for h in range(1, 5):
        out.append(2 * abs(np.mean(seg * np.exp(-2j * np.pi * h * f * t))))
    return np.array(out)


def iwan_closed(F_S, K_T, chi, beta):
    """phi_max, D and the micro-slip energy per cycle 4 R U^(3+chi)/((chi+2)(chi+3))."""
    d = beta + (chi + 1) / (chi + 2)
    phi_max = F_S * (1 + beta) / (K_T * d)
    R = F_S * (chi + 1) / (phi_max ** (chi + 2) * d)
    return phi_max, d, lambda U: 4 * R * U ** (chi + 3) / ((chi + 2) * (chi + 3))


# ---------------------------------------------------------------------------------------
def test_registry_matches_vocabulary_and_documents_every_effect():
    assert set(REGISTRY) == set(EFFECTS)
    for name, cls in REGISTRY.items():
        e = cls()
        assert e.kind == EFFECTS[name].kind
        assert e.param_names == tuple(p.name for p in EFFECTS[name].params)
        assert len(e.description.split()) > 25 and len(e.signature.split()) > 8


def test_base_class_is_enforced():
    from labjoint.models.effects.base import ForceEffect, HystereticEffect

    with pytest.raises(TypeError, match="not in the vocabulary"):
        type("Bogus", (ForceEffect,), {"name": "bogus", "description": "a " * 10,
                                       "signature": "b " * 10})
    with pytest.raises(TypeError, match="kind"):
        type("WrongKind", (HystereticEffect,), {"name": "viscous", "description": "a " * 10,
                                                "signature": "b " * 10})
    half = type("Half", (ForceEffect,), {"name": "viscous", "description": "a " * 10,
                                         "signature": "b " * 10})
    with pytest.raises(TypeError):
        half()  # abstract basis/guess not implemented


def test_viscous_ellipse_energy_is_pi_c_omega_U2():
    f, U, c, k = 200.0, 10e-6, 35.0, 3e6
    inp = tone(U, f, 6)
    F = Model.parse("linear_stiffness+viscous").eval({"linear_stiffness.k": k, "viscous.c": c}, inp)
    E = loop_energy(F, inp, f)
    assert E == pytest.approx(np.pi * c * 2 * np.pi * f * U ** 2, rel=1e-4)


def test_coulomb_jenkins_energy_and_no_loss_below_slip():
    k, fs_ = 2e7, 40.0
    m = Model.parse("coulomb")
    for U in (4e-6, 10e-6):
        F = m.eval({"coulomb.k": k, "coulomb.f_s": fs_}, tone(U, 100.0, 4))
        E = loop_energy(F, tone(U, 100.0, 4), 100.0)
        assert E == pytest.approx(4 * fs_ * (U - fs_ / k), rel=1e-3)
        assert np.max(F) == pytest.approx(fs_, rel=1e-12)
    small = tone(1e-6, 100.0, 3)  # U < f_s / k: sticks, no loss
    F = m.eval({"coulomb.k": k, "coulomb.f_s": fs_}, small)
    assert abs(loop_energy(F, small, 100.0)) < 1e-12
    np.testing.assert_allclose(F, k * (small.u - small.u[0]), atol=1e-9)


IWAN = dict(F_S=100.0, K_T=1e7, chi=-0.5, beta=0.3)


@pytest.mark.parametrize("engine", ["masing", "population"])
def test_iwan_micro_slip_energy_matches_segalman(engine):
    phi_max, _, energy = iwan_closed(**IWAN)
    m = Model.parse("iwan") if engine == "masing" else Model.parse("iwan+wear")
    vals = {f"iwan.{k}": v for k, v in IWAN.items()}
    if engine == "population":
        vals["wear.E_w"] = 1e30  # activates the slider population, no wear in practice
    for x in (0.01, 0.1, 0.5, 0.9):
        U = x * phi_max
        inp = tone(U, 50.0, 3, fs=51200.0)
        E = loop_energy(m.eval(vals, inp), inp, 50.0)
        assert E == pytest.approx(energy(U), rel=1e-3)


def test_iwan_power_law_exponent_and_macro_slip_force():
    for chi in (-0.6, 0.0, 0.4):
        p = dict(IWAN, chi=chi)
        phi_max, _, _ = iwan_closed(**p)
        vals = {f"iwan.{k}": v for k, v in p.items()}
        m = Model.parse("iwan")
        Us = np.array([0.01, 0.02, 0.04]) * phi_max
        E = [loop_energy(m.eval(vals, i), i, 50.0) for i in (tone(U, 50.0, 3) for U in Us)]
        slope = np.polyfit(np.log(Us), np.log(E), 1)[0]
        assert slope == pytest.approx(3 + chi, abs=1e-3)
        big = tone(3 * phi_max, 50.0, 3)
        assert np.max(m.eval(vals, big)) == pytest.approx(p["F_S"], rel=1e-9)
        tiny = ModelInputs.from_record(np.linspace(0, 1e-12 * phi_max, 64), FS)
        F = m.eval(vals, tiny)   # secant K_T (1 - x^(chi+1) / ((1+beta)(chi+2))), x = 1e-12
        assert F[-1] / tiny.u[-1] == pytest.approx(p["K_T"], rel=1e-4)


def test_iwan_population_discretisation_accuracy():
    for chi in (-0.9, -0.3, 0.5):
        phi_max, _, energy = iwan_closed(100.0, 1e7, chi, 0.2)
        k, f = iwan_population(100.0, 1e7, chi, 0.2)
        assert k.sum() == pytest.approx(1e7, rel=1e-12) and f.sum() == pytest.approx(100.0, rel=1e-12)
        for x in np.geomspace(1e-3, 0.99, 15):
            U = x * phi_max
            slip = f / k < U
            E = np.sum(4 * f[slip] * (U - f[slip] / k[slip]))  # each Jenkins: 4 f (U - f/k)
            assert E == pytest.approx(energy(U), rel=1e-3)


def test_bouc_wen_saturates_at_its_slip_force_with_initial_slope_k0():
    m = Model.parse("bouc_wen")
    ab = 0.5e7 / 30.0 ** 2          # alpha = beta: loading saturates at (k0 / (alpha + beta))^(1/n) = 30 N
    vals = {"bouc_wen.k0": 1e7, "bouc_wen.alpha": ab, "bouc_wen.beta": ab, "bouc_wen.n": 2.0}
    F = m.eval(vals, tone(50e-6, 100.0, 3))
    assert np.max(F) == pytest.approx(30.0, rel=1e-6)
    ramp = ModelInputs.from_record(np.linspace(0, 1e-10, 64), FS)
    assert m.eval(vals, ramp)[-1] / 1e-10 == pytest.approx(1e7, rel=1e-4)


def test_richard_abbott_backbone_is_seed000_eq2_and_masing_loops_close():
    ke, kp, Fy, n = 1e7, 1e6, 50.0, 3.6
    vals = {"richard_abbott.ke": ke, "richard_abbott.kp": kp, "richard_abbott.F_y": Fy,
            "richard_abbott.n": n}
    m = Model.parse("richard_abbott")

    def eq2(eps):  # seed 000 Eq. 2 with stress -> force, strain -> displacement
        return (ke - kp) * eps / (1 + np.abs((ke - kp) * eps / Fy) ** n) ** (1 / n) + kp * eps

    up = np.linspace(0, 30e-6, 400)
    F = m.eval(vals, ModelInputs.from_record(up, FS))
    np.testing.assert_allclose(F, eq2(up), rtol=1e-12, atol=1e-12)
    U = 30e-6
    down = np.concatenate([up, np.linspace(U, -U, 800)[1:], np.linspace(-U, U, 800)[1:]])
    F = m.eval(vals, ModelInputs.from_record(down, FS))
    seg = down[400:1199]
    np.testing.assert_allclose(F[400:1199], eq2(U) - 2 * eq2((U - seg) / 2), rtol=1e-12, atol=1e-9)
    assert F[1198] == pytest.approx(-eq2(U), rel=1e-12)        # symmetric tip
    assert F[-1] == pytest.approx(eq2(U), rel=1e-12)           # loop closes at the first tip
    # return-point memory: a minor loop inside rejoins the major branch where it left it
    minor = np.concatenate([down[:1000], np.linspace(down[999], down[999] + 8e-6, 50)[1:],
                            np.linspace(down[999] + 8e-6, down[999], 50)[1:],
                            np.linspace(down[999], -U, 300)[1:]])
    Fm = m.eval(vals, ModelInputs.from_record(minor, FS))
    assert Fm[-1] == pytest.approx(-eq2(U), rel=1e-9)


def test_richard_abbott_population_matches_masing():
    vals = {"ke": 1e7, "kp": 1e6, "F_y": 50.0, "n": 2.0}
    k, f, kel = RichardAbbott().population(vals)
    inp = tone(2 * 50 / 9e6, 50.0, 2)
    exact = Model.parse("richard_abbott").eval({f"richard_abbott.{a}": b for a, b in vals.items()}, inp)
    pop, _ = population_force(inp.u_hist, k, f, kel, 0.0, 0.0, np.zeros(inp.u_hist.size))
    assert np.max(np.abs(pop - exact)) < 1e-3 * np.max(np.abs(exact))


def test_valanis_initial_slope_E0_and_asymptotic_slope_Et():
    E0, Et, lam, kappa = 1e7, 5e5, 2e5, 0.3
    m = Model.parse("valanis")
    vals = {"valanis.E0": E0, "valanis.Et": Et, "valanis.lam": lam, "valanis.kappa": kappa}
    u = np.linspace(0, 500e-6, 20001)
    F = m.eval(vals, ModelInputs.from_record(u, FS))
    du = u[1] - u[0]
    assert (F[1] - F[0]) / du == pytest.approx(E0, rel=2e-3)
    assert (F[-1] - F[-2]) / du == pytest.approx(Et, rel=1e-3)
    wstar = E0 * (E0 - Et) / (lam * (E0 - kappa * Et))   # F - Et u -> slip strength
    assert F[-1] - Et * u[-1] == pytest.approx(wstar, rel=1e-3)


def test_cubic_stiffness_no_loss_and_stiffness_rising_with_amplitude():
    k3 = 1e15
    m = Model.parse("cubic_stiffness")
    keq = []
    for U in (5e-6, 20e-6):
        inp = tone(U, 100.0, 3)
        F = m.eval({"cubic_stiffness.k3": k3}, inp)
        assert abs(loop_energy(F, inp, 100.0)) < 1e-9 * np.max(np.abs(F)) * U
        keq.append(harmonics(F, 100.0, FS)[1] / U)
        assert keq[-1] == pytest.approx(0.75 * k3 * U ** 2, rel=1e-6)
    assert keq[1] > keq[0]


def test_inertia_apparent_stiffness_falls_with_frequency_squared():
    k, mass = 5e6, 0.2
    m = Model.parse("linear_stiffness+inertia")
    for f in (100.0, 400.0, 800.0):
        inp = tone(10e-6, f, 8 * f / 100.0)
        F = m.eval({"linear_stiffness.k": k, "inertia.m": mass}, inp)
        A = np.column_stack([inp.u, inp.v])
        keq = np.linalg.lstsq(A[200:-200], F[200:-200], rcond=None)[0][0]
        assert keq == pytest.approx(k - mass * (2 * np.pi * f) ** 2, rel=1e-5)


def test_offset_and_asymmetric_slip_make_even_harmonics_symmetric_models_do_not():
    inp = tone(20e-6, 100.0, 5)
    sym = {"coulomb.k": 2e7, "coulomb.f_s": 40.0}
    h = harmonics(Model.parse("coulomb").eval(sym, inp), 100.0, FS)
    assert h[0] < 1e-9 * h[1] and h[2] < 1e-9 * h[1]
    h = harmonics(Model.parse("coulomb+offset").eval({**sym, "offset.F0": 3.0}, inp), 100.0, FS)
    assert h[0] == pytest.approx(3.0, rel=1e-9)
    h = harmonics(Model.parse("coulomb+asymmetric_slip").eval({**sym, "asymmetric_slip.asym": 0.2},
                                                              inp), 100.0, FS)
    assert h[0] == pytest.approx(0.2 * 40.0, rel=1e-6)   # plateaus at +48 N and -32 N
    ab = 0.5e7 / 30.0 ** 1.5
    bw = {"bouc_wen.k0": 1e7, "bouc_wen.alpha": ab, "bouc_wen.beta": ab, "bouc_wen.n": 1.5}
    h_sym = harmonics(Model.parse("bouc_wen").eval(bw, inp), 100.0, FS)
    h_asym = harmonics(Model.parse("bouc_wen+asymmetric_slip").eval(
        {**bw, "asymmetric_slip.asym": 0.2}, inp), 100.0, FS)
    assert h_sym[2] < 1e-6 * h_sym[1] and h_asym[2] > 1e-2 * h_asym[1]


def test_wear_loss_decays_over_cycles_like_a_reference_integration():
    k, fs_, Ew = 2e7, 40.0, 0.05
    inp = tone(20e-6, 100.0, 20)
    F = Model.parse("coulomb+wear").eval({"coulomb.k": k, "coulomb.f_s": fs_, "wear.E_w": Ew}, inp)
    # straightforward reference: a Jenkins element whose slider weakens with its own work
    q, ed, ref = 0.0, 0.0, [0.0]
    u = inp.u
    for i in range(1, u.size):
        s = fs_ * np.exp(-ed / Ew)
        trial = q + k * (u[i] - u[i - 1])
        q = min(max(trial, -s), s)
        ed += s * abs(trial - q) / k
        ref.append(q)
    np.testing.assert_allclose(F, ref, rtol=1e-9, atol=1e-9)
    per = int(FS / 100.0)
    E = [np.sum(F[i * per:(i + 1) * per] * np.gradient(u)[i * per:(i + 1) * per]) for i in range(1, 19)]
    assert np.all(np.diff(E) < 0)


def test_backlash_zero_force_inside_the_gap():
    gap, k = 6e-6, 1e7
    inp = tone(10e-6, 100.0, 2)
    F = Model.parse("linear_stiffness+backlash").eval({"linear_stiffness.k": k, "backlash.gap": gap}, inp)
    inside = np.abs(inp.u) < gap / 2
    assert inside.any() and np.all(F[inside] == 0.0)
    np.testing.assert_allclose(F[~inside], k * np.sign(inp.u[~inside]) * (np.abs(inp.u[~inside]) - gap / 2),
                               rtol=1e-12)


def test_channel_delay_loop_area_is_pi_F_U_sin_omega_tau():
    k, U, f = 1e7, 10e-6, 200.0
    m = Model.parse("linear_stiffness+channel_delay")
    for tau in (13.3e-6, 57.9e-6):   # fractional samples
        inp = tone(U, f, 8)
        F = m.eval({"linear_stiffness.k": k, "channel_delay.tau": tau}, inp)
        E = loop_energy(F, inp, f, skip=2)
        # a lagging force turns the loop the generating way: area -pi F U sin(omega tau)
        assert E == pytest.approx(-np.pi * (k * U) * U * np.sin(2 * np.pi * f * tau), rel=1e-3)
