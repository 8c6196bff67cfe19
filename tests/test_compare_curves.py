"""Physics curves: loss-free model points are named, not fed to the log-log trends."""

import numpy as np

from labjoint.compare import evaluate, noise_floor, physics_curves, prepare_runs, residual_maps
from labjoint.compare.describe import failures
from labjoint.models import Model, ModelFitter
from test_compare_synth import sweep


def test_a_loss_free_model_is_reported_and_kept_out_of_the_slopes():
    runs = prepare_runs(sweep(c=150.0))          # viscous loss: W = pi c w U^2
    model = Model.parse("linear_stiffness")      # no loss at all
    fit = ModelFitter(model).fit([r.data for r in runs])
    ev = evaluate(model, fit.params_, runs)
    c = physics_curves(ev)
    assert sorted(c.lossless["model"]) == sorted(r.name for r in runs)
    assert c.lossless["measured"] == []
    # measured slope of a linear loss is 2 in amplitude, 1 in frequency
    assert all(abs(s - 2.0) < 0.1 for s in c.energy_slope["measured"].values())
    assert abs(c.frequency_exponent["measured"] - 1.0) < 0.1
    # no trend is fitted through loss-free points
    assert all(np.isnan(s) for s in c.energy_slope["model"].values())
    nf = noise_floor(runs)
    text = [f["text"] for f in failures(ev, residual_maps(ev, nf.by_run()), c, nf.nrmse)]
    assert any("dissipates almost nothing in 9 of 9 runs" in t for t in text), text
