"""The comparison loop on FRF sets of a structure (the ``frf`` kind): diagnose and ladder
with a hidden Iwan + viscous joint against a linear baseline, and a null case."""

import numpy as np
import pytest

from frfdata import hidden_law, hidden_set, predictor
from labjoint.compare.diagnosis import DiagnoseSettings, diagnose_prepared
from labjoint.compare.kinds import kind_of
from labjoint.compare.kinds.frf import prepare_frfsets
from labjoint.compare.ladders import build_ladder
from labjoint.errors import InputError
from labjoint.structure.law import JointLaw

CANDIDATES = DiagnoseSettings(candidates=("viscous", "iwan"))


@pytest.fixture(scope="module")
def pr():
    return predictor()


def test_prepared_measurements_split_and_noise(pr):
    ms = prepare_frfsets([("sim", hidden_set(pr, hidden_law(), steps=4))], pr)
    assert [m.name for m in ms] == ["sim@2N-up-mode1", "sim@5N-up-mode1", "sim@10N-up-mode1"]
    kind = kind_of(ms)
    fit, val, rule = kind.split(ms)
    assert [m.level_n for m in val] == [5.0] and "level" in rule
    # whitened: the floor is 1 / rms of the whitened measurement, i.e. the noise over the signal
    m = ms[0]
    assert m.noise().equivalent_std == 1.0
    assert m.noise().nrmse == pytest.approx(1 / np.sqrt(np.mean(m.data.force ** 2)))
    # the truth predicts the data within its noise: whitened residual ~ unit variance
    truth = hidden_law()
    r = m.predict(truth.model, truth.params) - m.data.force
    assert 0.5 < np.sqrt(np.mean(r ** 2)) < 1.5


def test_ladder_finds_the_dissipation_and_the_error_falls_to_the_noise(pr):
    ms = prepare_frfsets([("sim", hidden_set(pr, hidden_law(), steps=5))], pr)
    lad = build_ladder(ms, "linear_stiffness", settings=CANDIDATES, max_steps=2)
    d = lad.to_dict(full=True)
    steps = d["steps"]
    assert steps[0]["model"] == "linear_stiffness"
    first = steps[0]
    assert not first["adequate"]
    assert first["verdict"].startswith("add ")
    # the first effect named is one that dissipates energy (viscous or Iwan micro-slip)
    assert steps[1]["added"] in ("viscous", "iwan")
    nrmse = [s["nrmse_validation"] for s in steps]
    assert all(b < a for a, b in zip(nrmse, nrmse[1:]))
    assert nrmse[-1] < 2 * d["noise_floor_validation"] < 0.1 * nrmse[0]
    assert d["adequate"]
    maps = d["final_diagnosis"]["maps"]
    assert {c["harmonic"] for c in maps["cells"]} == {1, 2, 3}
    assert set(maps["residual_over_noise_by_harmonic"]) == {"1", "2", "3"}
    # where the linear model failed: at mode 1, the resonance, harmonic 1
    fails = lad.steps[0].diagnosis.failures
    assert fails and fails[0]["text"].startswith("mode 1,") and "harmonic 1" in fails[0]["text"]


def test_null_case_adds_nothing(pr):
    lin = JointLaw("linear_stiffness", {"linear_stiffness.k": 1e10})
    ms = prepare_frfsets([("lin", hidden_set(pr, lin, steps=6, seed=5))], pr)
    dg = diagnose_prepared(ms, "linear_stiffness", settings=CANDIDATES)
    assert dg.adequate and dg.best is None
    assert dg.nrmse < 1.5 * dg.noise.nrmse
    k = dg.base.params_["linear_stiffness.k"]
    assert abs(k.value - 1e10) < 3 * k.stderr


def test_effect_that_is_no_joint_law_is_refused(pr):
    ms = prepare_frfsets([("lin", hidden_set(pr, None, steps=3))], pr)
    with pytest.raises(InputError) as e:
        kind_of(ms).fit("coulomb+wear", ms)
    assert e.value.field == "model" and "wear" in e.value.message and "steady periodic" in e.value.message


def test_harmonics_count_in_the_error_and_the_maps(pr):
    """A model that explains harmonic 1 but not a measured harmonic 3 is judged worse, and
    the map puts the misfit at harmonic 3 (what ranks candidates is this same error)."""
    from labjoint.compare.metrics import evaluate
    from labjoint.signal.frfset import FrfSet

    truth = hidden_law()
    fs = hidden_set(pr, truth, steps=4)
    resp = fs.response.copy()
    resp[:, :, 2] += 20 * fs.response_std[:, :, 2]          # a third harmonic the model lacks
    bent = FrfSet(fs.frequencies_hz, fs.level_n, fs.direction, fs.force, fs.sensors, resp,
                  fs.response_std)
    kind = kind_of(prepare_frfsets([("a", fs)], pr))
    errs, maps = [], []
    for s in (fs, bent):
        ms = prepare_frfsets([("a", s)], pr)
        ev = evaluate(truth.model, truth.params, ms, loops=False)
        errs.append(ev.nrmse())
        maps.append(kind.maps(ev.runs, {}).by_harmonic())
    assert errs[1] > 3 * errs[0]
    assert maps[0][3] < 1.5 and maps[1][3] > 10
    assert maps[1][1] == pytest.approx(maps[0][1])
