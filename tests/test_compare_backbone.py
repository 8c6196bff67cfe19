"""The comparison loop on backbones (the ``backbone`` kind): a measured backbone made here
from the structure with a hidden Iwan joint (EPMC; the FRF tests' Iwan parameters) plus
stated noise, judged against a linear baseline."""

import numpy as np
import pytest

from frfdata import HIDDEN, predictor
from labjoint.compare.diagnosis import DiagnoseSettings, diagnose_prepared
from labjoint.compare.kinds import KINDS, kind_of, prepare
from labjoint.compare.kinds.backbone import prepare_backbones
from labjoint.compare.ladders import build_ladder
from labjoint.errors import InputError
from labjoint.signal.backbone import Backbone, BackbonePoint
from labjoint.structure.epmc import EPMC
from labjoint.structure.law import JointLaw

F_SD, Z_SD = 2e-4, 0.02          # Hz; relative


def hidden_law():
    return JointLaw("iwan", {k: v for k, v in HIDDEN.items() if k.startswith("iwan.")})


@pytest.fixture(scope="module")
def pr():
    return predictor()


def measured(pr, law, n=24, seed=1):
    rng = np.random.default_rng(seed)
    b, _ = EPMC(pr.system_with(law), 0, 3, 32, "free_end").backbone(np.geomspace(2e-5, 2e-3, n))
    pts = [BackbonePoint(p.amplitude, p.frequency_hz + F_SD * rng.standard_normal(), 
                         p.damping_ratio * (1 + Z_SD * rng.standard_normal()), "phase_resonance",
                         0.0, F_SD, Z_SD * p.damping_ratio) for p in b.points]
    return Backbone(pts, "m", "displacement", "free_end")


def test_prepared_split_noise_and_the_truth_within_its_noise(pr):
    ms = prepare_backbones([("pr", measured(pr, hidden_law()))], pr)
    assert [m.name for m in ms] == ["pr/even", "pr/odd"] and KINDS["backbone"] is kind_of(ms)
    fit, val, rule = kind_of(ms).split(ms)
    assert [m.name for m in fit] == ["pr/even"] and [m.name for m in val] == ["pr/odd"]
    m = ms[0]
    assert m.noise().equivalent_std == 1.0
    truth = hidden_law()
    r = m.predict(truth.model, truth.params) - m.data.force
    assert 0.4 < np.sqrt(np.mean(r ** 2)) < 1.6                 # whitened: unit variance
    with pytest.raises(InputError):
        prepare(["x.h5"], kind="backbone")


@pytest.mark.slow
def test_linear_baseline_fails_in_the_fields_words_and_the_ladder_finds_the_slip(pr):
    ms = prepare_backbones([("pr", measured(pr, hidden_law()))], pr)
    dg = diagnose_prepared(ms, "linear_stiffness", settings=DiagnoseSettings(candidates=("viscous", "iwan")))
    texts = [f["text"] for f in dg.failures]
    assert any(t.startswith("damping too low above") for t in texts), texts
    lad = build_ladder(ms, "linear_stiffness", settings=DiagnoseSettings(candidates=("viscous", "iwan")),
                       max_steps=2)
    d = lad.to_dict(full=True)
    added = [s.get("added") for s in d["steps"][1:]]
    assert "iwan" in added                                       # the hysteretic slip law is named
    nrmse = [s["nrmse_validation"] for s in d["steps"]]
    assert nrmse[-1] < 2 * d["noise_floor_validation"] < 0.2 * nrmse[0]
