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
