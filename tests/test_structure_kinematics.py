"""Joint kinematics (issue 32): odd laws act in shear through the patches, the even part of
any law acts in the normal direction (the layer's opening r theta), refused effects are
named. Checked against closed forms of the patch sums, not against the code's own sums."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.structure import JointLaw, load_structure
from labjoint.structure.frf import response_at
from labjoint.structure.joint import refusal

SEED000 = Path(__file__).resolve().parent.parent / "configs" / "structure-seed000.toml"
K = 3.3e8


@pytest.fixture(scope="module")
def seed000():
    return load_structure(SEED000)


def joint_with(structure, model, params):
    return replace(structure.joints[0], law=JointLaw(model, params))


def test_odd_and_even_parts_of_a_polynomial_law_against_the_closed_form(seed000):
    k3, F0 = 4e17, 800.0
    j = joint_with(seed000, "linear_stiffness+cubic_stiffness+offset",
                   {"linear_stiffness.k": K, "cubic_stiffness.k3": k3, "offset.F0": F0})
    r, n = j.radius_m, 64
    t = 2 * np.pi * np.arange(n) / n
    th = 2e-6 + 1e-5 * np.cos(t)
    thd, thdd = -1e-5 * np.sin(t), -1e-5 * np.cos(t)
    M = j.moment_periodic(th, thd, thdd, n / 1.0)[0]
    # mean of cos^2 and cos^4 over equally spaced angles (more than 4 of them): 1/2, 3/8
    closed = K * r ** 2 / 2 * th + 3 / 8 * k3 * r ** 4 * th ** 3 + r * F0
    assert np.max(np.abs(M - closed)) < 1e-9 * np.max(np.abs(closed))


def test_asymmetric_slip_shifts_the_mean_moment_by_its_even_part(seed000):
    fs, a, kc = 200.0, 0.4, 1e9
    j = joint_with(seed000, "coulomb+asymmetric_slip",
                   {"coulomb.k": kc, "coulomb.f_s": fs, "asymmetric_slip.asym": a})
    r, n = j.radius_m, 512
    t = 2 * np.pi * np.arange(n) / n
    amp = 200 * fs / kc / r                       # slips 200x its stick range: saturated
    M = j.moment_periodic(amp * np.cos(t), -amp * np.sin(t), -amp * np.cos(t), n)[0]
    # saturated, the patch force is (1 + a) f_s sliding up and -(1 - a) f_s down: even part a f_s
    assert np.mean(M) == pytest.approx(r * a * fs, rel=0.03)
    sym = joint_with(seed000, "coulomb", {"coulomb.k": kc, "coulomb.f_s": fs})
    Ms = sym.moment_periodic(amp * np.cos(t), -amp * np.sin(t), -amp * np.cos(t), n)[0]
    assert abs(np.mean(Ms)) < 1e-9 * np.max(np.abs(Ms))


def test_a_preloaded_cubic_joint_makes_harmonic_2_in_the_structure_and_a_plain_one_does_not(seed000):
    def h2_over_h1(model, params):
        law = JointLaw(model, params)
        st = seed000.with_joints(tuple(replace(j, law=law) for j in seed000.joints))
        ph = response_at(st, [28.0], 16.5, harmonics=3, modes=6)[0, :, 2]   # free end
        return abs(ph[2]) / abs(ph[1]), abs(ph[3]) / abs(ph[1])
    base = {"linear_stiffness.k": K, "cubic_stiffness.k3": 1e18}
    h2, h3 = h2_over_h1("linear_stiffness+cubic_stiffness", base)
    assert h2 < 1e-12 and h3 > 1e-4                  # odd law: hardening, odd harmonics only
    h2p, _ = h2_over_h1("linear_stiffness+cubic_stiffness+offset", {**base, "offset.F0": 3000.0})
    assert h2p > 1e-3                                # the preload breaks the symmetry


@pytest.mark.parametrize("effect,word", [("wear", "steady periodic"), ("channel_delay", "channels")])
def test_an_effect_that_cannot_act_in_a_joint_is_refused_by_name(tmp_path, effect, word):
    assert word in refusal(effect)
    text = SEED000.read_text().replace('model = "richard_abbott"', f'model = "richard_abbott+{effect}"', 1)
    extra = {"wear": '"wear.E_w" = 1.0', "channel_delay": '"channel_delay.tau" = 1e-4'}[effect]
    text = text.replace("[joints.layer]", f"[joints.params]\n{extra}\n[joints.layer]", 1)
    p = tmp_path / "s.toml"
    p.write_text(text)
    with pytest.raises(InputError) as e:
        load_structure(p)
    assert effect in str(e.value) and word in str(e.value) and "thread_short" in str(e.value)


def test_every_other_effect_acts(seed000):
    assert [n for n in ("offset", "asymmetric_slip", "backlash", "cubic_stiffness", "iwan",
                        "richard_abbott", "bouc_wen", "valanis", "inertia") if refusal(n)] == []


@pytest.mark.parametrize("model,params", [
    ("iwan", {"iwan.F_S": 50.0, "iwan.K_T": 1e7, "iwan.chi": -0.4, "iwan.beta": 0.2}),
    ("linear_stiffness+iwan+viscous+cubic_stiffness",
     {"linear_stiffness.k": 3e6, "iwan.F_S": 50.0, "iwan.K_T": 1e7, "iwan.chi": -0.4, "iwan.beta": 0.2,
      "viscous.c": 30.0, "cubic_stiffness.k3": 1e15}),
    ("linear_stiffness+offset+cubic_stiffness",
     {"linear_stiffness.k": 3e6, "offset.F0": 5.0, "cubic_stiffness.k3": 1e15}),
])
def test_batched_periodic_law_equals_the_model_along_each_primed_history(model, params):
    """The batched evaluation (memoryless terms in one call, hysteretic ones directly)
    is the model's force along the documented history: 0, then 3 periods from the top."""
    from labjoint.models import ModelInputs
    from labjoint.structure.law import PRIME_PERIODS
    law = JointLaw(model, params)
    n, fs = 48, 48 * 30.0
    t = np.arange(n) / fs
    w = 2 * np.pi * 30.0
    amps = np.array([1e-6, 8e-6, 3e-5])[:, None]
    u = amps * (np.cos(w * t + 0.3) + 0.2 * np.cos(3 * w * t))
    v = amps * (-w * np.sin(w * t + 0.3) - 0.6 * w * np.sin(3 * w * t))
    a = amps * (-w * w * np.cos(w * t + 0.3) - 1.8 * w * w * np.cos(3 * w * t))
    got = law.periodic(u, v, a, fs)
    for k in range(3):
        i0 = int(np.argmax(u[k]))
        idx = (np.arange(n) + i0) % n
        h = [np.r_[0.0, np.tile(x[k][idx], PRIME_PERIODS)] for x in (u, v, a)]
        ref = law.model.eval(law.params, ModelInputs(*h, fs, 1 + (PRIME_PERIODS - 1) * n))
        assert np.allclose(got[k][idx], ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))


def test_two_joint_stiffnesses_place_both_bending_modes(seed000):
    """Issue 32 item 5: rotational (the layer's E_e) and translational stiffness together
    put seed 000's measured 28.5 and 177 Hz on modes 1 and 2 (one stiffness could not)."""
    from frfdata import seed000_steel
    from labjoint.structure.modal import update_stiffness
    steel = seed000_steel(seed000)
    one = update_stiffness(steel, [28.5, 177.0])
    assert abs(one.updated_hz[1] / 177.0 - 1) > 0.02
    two = update_stiffness(steel, [28.5, 177.0], "E_e_pa,transverse_stiffness_n_per_m")
    assert np.allclose(two.updated_hz, [28.5, 177.0], rtol=1e-4)
    d = two.to_dict()["parameters"]
    assert d["transverse_stiffness_n_per_m"]["unit"] == "N/m"
    assert 1e7 < d["E_e_pa"]["value"] < 1e8 and d["transverse_stiffness_n_per_m"]["value"] > 0
