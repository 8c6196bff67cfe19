"""Issue 32 item 2: a linear-in-parameter term (cubic stiffness) starts from the data, not at
zero, so the diagnosis of a hardening joint names it and recovers k3 (the search from
k3 = 0 had returned k3 = 0 with the baseline's NRMSE)."""

import numpy as np
import pytest

from frfdata import hidden_set, predictor
from labjoint.compare.diagnosis import DiagnoseSettings, diagnose_prepared
from labjoint.compare.kinds.frf import prepare_frfsets
from labjoint.compare.kinds.frf_fit import fit_frf, sign_starts, slip_amplitude
from labjoint.models import Model
from labjoint.structure.law import JointLaw

K = 1e10


@pytest.fixture(scope="module")
def pr():
    return predictor()


def cubic_law(pr, sign=1.0):
    base = prepare_frfsets([("lin", hidden_set(pr, None, steps=3))], pr)
    u = slip_amplitude(base, Model.parse("linear_stiffness"), {"linear_stiffness.k": K})
    return JointLaw("linear_stiffness+cubic_stiffness",
                    {"linear_stiffness.k": K, "cubic_stiffness.k3": sign * 0.3 * K / u ** 2})


def test_a_hardening_joint_is_named_cubic_stiffness_and_k3_recovered(pr):
    law = cubic_law(pr)
    ms = prepare_frfsets([("cub", hidden_set(pr, law, steps=8))], pr)
    dg = diagnose_prepared(ms, "linear_stiffness",
                           settings=DiagnoseSettings(candidates=("viscous", "iwan", "cubic_stiffness", "offset")))
    assert dg.best is not None and dg.best.effect == "cubic_stiffness"
    p = dg.best.fit.params_["cubic_stiffness.k3"]
    assert abs(p.value - law.params["cubic_stiffness.k3"]) < 3 * p.stderr
    assert dg.best.nrmse_after_validation < 1.5 * dg.noise.nrmse < dg.nrmse


def test_softening_is_found_from_the_mirrored_start(pr):
    law = cubic_law(pr, -0.15)
    ms = prepare_frfsets([("cub", hidden_set(pr, law, steps=6))], pr)
    fit = fit_frf("linear_stiffness+cubic_stiffness", ms[::2], ms[1::2])
    k3 = fit.params_["cubic_stiffness.k3"]
    assert k3.value < 0 and abs(k3.value - law.params["cubic_stiffness.k3"]) < 3 * k3.stderr
    assert len(sign_starts(Model.parse("cubic_stiffness+offset"),
                           {"cubic_stiffness.k3": 1.0, "offset.F0": 2.0},
                           ["cubic_stiffness.k3", "offset.F0"])) == 4


def test_starts_of_input_and_modifier_effects_come_from_the_slip_amplitude(pr):
    from labjoint.compare.kinds.frf_fit import start_values
    ms = prepare_frfsets([("lin", hidden_set(pr, None, steps=3))], pr)
    u = slip_amplitude(ms, Model.parse("linear_stiffness"), {"linear_stiffness.k": K})
    s = start_values(Model.parse("linear_stiffness+backlash"), ms, {"linear_stiffness.k": K})
    assert s["backlash.gap"] == pytest.approx(u / 2) and s["linear_stiffness.k"] == K
