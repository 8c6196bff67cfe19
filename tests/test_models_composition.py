"""Model composition: parsing, prefixing, refusals, components, serialisation."""

from __future__ import annotations

import json

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.models import Model, ModelInputs, Parameters
from labjoint.vocabulary import EFFECTS

FS = 25600.0


def inputs(U=15e-6, f=100.0, cycles=4):
    t = np.arange(int(cycles * FS / f)) / FS
    return ModelInputs.from_record(U * np.sin(2 * np.pi * f * t), FS, frequency_hz=f)


FULL = {"linear_stiffness.k": 2e6, "viscous.c": 20.0, "iwan.F_S": 60.0, "iwan.K_T": 1e7,
        "iwan.chi": -0.3, "iwan.beta": 0.2, "cubic_stiffness.k3": 1e14, "offset.F0": 1.5,
        "inertia.m": 0.05, "wear.E_w": 5.0, "asymmetric_slip.asym": 0.1, "backlash.gap": 1e-6,
        "channel_delay.tau": 7e-6}
EXPR = ("linear_stiffness+viscous+iwan+cubic_stiffness+offset+inertia+wear+asymmetric_slip"
        "+backlash+channel_delay")


def test_parse_prefixes_parameters_and_adds():
    m = Model.parse(" linear_stiffness + Iwan ")
    assert m.expr == "linear_stiffness+iwan"
    assert m.param_names == ("linear_stiffness.k", "iwan.F_S", "iwan.K_T", "iwan.chi", "iwan.beta")
    assert (m + "viscous").expr == (m + Model.parse("viscous")).expr == "linear_stiffness+iwan+viscous"
    p = m.make_params({"iwan.K_T": 1e7})
    assert p["iwan.K_T"].unit == "N/m" and p["iwan.chi"].lower == -1.0 and np.isnan(p["iwan.F_S"].value)


def test_refusals_are_clear():
    with pytest.raises(InputError, match="more than once"):
        Model.parse("iwan+linear_stiffness+iwan")
    with pytest.raises(InputError, match="more than once"):
        Model.parse("coulomb") + "coulomb"
    with pytest.raises(InputError) as e:
        Model.parse("linear_stiffness+friction")
    assert "friction" in str(e.value) and all(n in str(e.value) for n in EFFECTS)
    with pytest.raises(InputError, match="hysteretic"):
        Model.parse("linear_stiffness+wear")
    with pytest.raises(InputError, match="empty"):
        Model.parse("linear_stiffness++viscous")
    m = Model.parse("linear_stiffness+iwan")
    with pytest.raises(InputError, match="iwan.K_T"):
        m.eval({"linear_stiffness.k": 1.0, "iwan.F_S": 1.0, "iwan.chi": 0.0, "iwan.beta": 0.1}, inputs())
    with pytest.raises(InputError, match="iwan.chi"):
        m.eval({"linear_stiffness.k": 1.0, "iwan.F_S": 1.0, "iwan.K_T": 1e6, "iwan.chi": 2.0,
                "iwan.beta": 0.1}, inputs())
    with pytest.raises(InputError, match="iwan.bogus"):
        m.make_params({"iwan.bogus": 1.0})


def test_components_sum_to_eval_and_each_is_its_effect_alone():
    m = Model.parse(EXPR)
    inp = inputs()
    F = m.eval(FULL, inp)
    comps = m.eval_components(FULL, inp)
    assert list(comps) == list(m.names)
    np.testing.assert_allclose(sum(comps.values()), F, rtol=0, atol=1e-12 * np.max(np.abs(F)))
    assert np.all(comps["wear"] == 0) and np.all(comps["channel_delay"] == 0)
    np.testing.assert_allclose(comps["offset"], 1.5)
    # a force effect's component equals the effect evaluated alone on the same history
    simple = Model.parse("linear_stiffness+viscous+iwan")
    vals = {k: v for k, v in FULL.items() if k.split(".")[0] in simple.names}
    parts = simple.eval_components(vals, inp)
    np.testing.assert_allclose(parts["viscous"], Model.parse("viscous").eval({"viscous.c": 20.0}, inp))


def test_to_dict_from_dict_round_trip_through_json():
    m = Model.parse(EXPR)
    p = m.make_params(FULL)
    p.set("iwan.chi", vary=False)
    d = json.loads(json.dumps(m.to_dict(p)))
    assert d["effects"] == list(m.names) and d["params"]["linear_stiffness.k"]["upper"] is None
    m2, p2 = Model.from_dict(d)
    assert m2 == m and isinstance(p2, Parameters) and p2["iwan.chi"].vary is False
    inp = inputs()
    np.testing.assert_array_equal(m2.eval(p2, inp), m.eval(p, inp))
    with pytest.raises(InputError, match="do not match"):
        Model.from_dict({"effects": ["iwan"], "params": d["params"]})


def test_wear_coupled_over_two_hysteretic_effects_converges():
    """Wear scales every slider by the joint's total dissipation: the Picard solution equals
    a direct simulation of both Jenkins elements together."""
    from labjoint.models.effects._population import population_force

    m = Model.parse("coulomb+richard_abbott+wear")
    vals = {"coulomb.k": 2e7, "coulomb.f_s": 30.0, "richard_abbott.ke": 1e7, "richard_abbott.kp": 0.0,
            "richard_abbott.F_y": 20.0, "richard_abbott.n": 50.0, "wear.E_w": 0.02}
    inp = inputs(U=20e-6, cycles=6)
    F = m.eval(vals, inp)
    k_ra, f_ra, _ = m.effect("richard_abbott").population(
        {"ke": 1e7, "kp": 0.0, "F_y": 20.0, "n": 50.0})
    both, _ = population_force(inp.u_hist, np.r_[2e7, k_ra], np.r_[30.0, f_ra], 0.0, 0.0, 1 / 0.02,
                               np.zeros(inp.u_hist.size))
    np.testing.assert_allclose(F, both, atol=1e-6 * np.max(np.abs(both)))


def test_reused_histories_are_never_stale():
    """Model._simulated keeps each hysteretic effect's history for reuse while its
    parameters and the displacement are the same: a changed parameter, modifier or
    displacement (even refilled in place) gives what a fresh model computes."""
    expr = "linear_stiffness+iwan+bouc_wen"
    p = {"linear_stiffness.k": 1e6, "iwan.F_S": 60.0, "iwan.K_T": 1e7, "iwan.chi": -0.3,
         "iwan.beta": 0.2, "bouc_wen.k0": 5e6, "bouc_wen.alpha": 400.0,
         "bouc_wen.beta": 300.0, "bouc_wen.n": 2.0}
    m, x = Model.parse(expr), inputs()
    first = m.eval(p, x)
    assert np.array_equal(m.eval(p, x), first)
    for key, value in (("bouc_wen.alpha", 900.0), ("iwan.F_S", 40.0)):
        q = {**p, key: value}
        got = m.eval(q, x)
        assert np.array_equal(got, Model.parse(expr).eval(q, x)) and not np.allclose(got, first)
    x.u_hist[:] *= 1.5                                  # the same buffer, new values
    assert np.array_equal(m.eval(p, x), Model.parse(expr).eval(p, x))
    asym = {**p, "asymmetric_slip.asym": 0.2}
    both = Model.parse(expr + "+asymmetric_slip")
    assert np.array_equal(both.eval(asym, x), Model.parse(expr + "+asymmetric_slip").eval(asym, x))
    comps = m.eval_components(p, x)
    with pytest.raises(ValueError):                     # kept histories are read-only
        comps["iwan"][0] = 0.0
    assert "_history_cache" not in m.__getstate__()
