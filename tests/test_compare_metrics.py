"""NRMSE pooled and per run, energy-loss and stiffness errors against closed forms."""

import numpy as np
import pytest

from labjoint.compare.metrics import evaluate
from labjoint.compare.runs import prepare_runs
from labjoint.models import Model
from test_compare_synth import sweep


@pytest.fixture(scope="module")
def runs():
    return prepare_runs(sweep(k=1e7, c=120.0, noise_f=0.0, cycles=16))


def test_nrmse_of_a_scaled_model_is_the_scale_error(runs):
    ev = evaluate(Model.parse("linear_stiffness+viscous"),
                  {"linear_stiffness.k": 0.9e7, "viscous.c": 0.9 * 120.0}, runs)
    assert ev.nrmse() == pytest.approx(0.1, rel=1e-3)
    assert all(v == pytest.approx(0.1, rel=1e-3) for v in ev.by_run().values())


def test_pooled_nrmse_weighs_runs_by_their_samples_and_force(runs):
    ev = evaluate(Model.parse("linear_stiffness"), {"linear_stiffness.k": 1e7}, runs)
    sse = sum(r.sse for r in ev.runs)
    ssf = sum(r.ssf for r in ev.runs)
    assert ev.nrmse() == pytest.approx(np.sqrt(sse / ssf))
    per = np.array(list(ev.by_run().values()))
    assert per.min() < ev.nrmse() < per.max()
    # one run on its own is its per-run NRMSE
    name = runs[0].name
    assert ev.nrmse([name]) == pytest.approx(ev.by_run()[name])


def test_energy_and_stiffness_errors_follow_the_loop_closed_forms(runs):
    """Seed 002 Eq. 1: W = pi c omega U^2 for a viscous loop; the loop slope is k."""
    ev = evaluate(Model.parse("linear_stiffness+viscous"),
                  {"linear_stiffness.k": 1.05e7, "viscous.c": 90.0}, runs)
    for r in ev.runs:
        assert r.energy_loss_error_pct == pytest.approx(100 * (90.0 - 120.0) / 120.0, abs=0.1)
        assert r.stiffness_error_pct == pytest.approx(5.0, abs=0.05)
        w = 2 * np.pi * r.run.frequency_hz
        assert r.energy_measured == pytest.approx(np.pi * 120.0 * w * r.run.amplitude_m ** 2, rel=3e-3)
        d = r.to_dict()
        assert set(d) >= {"run", "nrmse", "energy_loss_error_pct", "stiffness_error_pct"}
