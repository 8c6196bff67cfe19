"""Kinds judged together (compare/kinds/combined.py) and what known noise changes in the
judging: candidates of whitened data are told apart by the stated noise, not by the
spread of very unequal units (a backbone band hundreds of uncertainties off beside FRF
phasors a candidate barely moves)."""

from types import SimpleNamespace

import numpy as np

from labjoint.compare.metrics import Evaluation, RunEval
from labjoint.compare.significance import SignificanceSettings, noise_test
from labjoint.compare.ties import mark_ties


def _run(name, force, units):
    data = SimpleNamespace(force=force, steady=np.ones(force.size, bool))
    return SimpleNamespace(name=name, data=data, units=lambda: units)


def _setup(seed=0):
    """Validation data of unit noise: 40 'phasor' units near the model and 2 'bands' where
    the baseline misses by 300 sigma; candidate a fixes the bands, b only halves them."""
    rng = np.random.default_rng(seed)
    n = 40 + 2 * 4
    truth = np.concatenate([np.full(40, 50.0), np.full(8, 1e4)])
    meas = truth + rng.standard_normal(n)
    units = np.column_stack([np.r_[np.arange(40), 40, 44], np.r_[np.arange(1, 41), 44, 48]])
    run = _run("v", meas, units)
    base = truth.copy()
    base[40:] -= 300.0
    half = truth.copy()
    half[40:] -= 150.0
    ev = lambda f: Evaluation(None, None, (RunEval(run, f),))  # noqa: E731
    b_ev, a_ev, h_ev = ev(base), ev(truth), ev(half)
    cand = lambda name, e: SimpleNamespace(effect=name, significant=True, evaluation=e, tie_with=[],  # noqa: E731
                                           tie_reason="", nrmse_after_validation=e.nrmse())
    return b_ev, cand("iwan", a_ev), cand("viscous", h_ev), float(np.sqrt(n / (meas @ meas)))


def test_known_noise_tells_apart_what_the_units_spread_cannot():
    b_ev, a, h, floor = _setup()
    s = SignificanceSettings()
    mark_ties([a, h], b_ev, ["v"], floor, s)
    assert a.tie_with == ["viscous"]                 # 2 bands beside 40 quiet units: "a tie"
    b_ev, a, h, floor = _setup()
    mark_ties([a, h], b_ev, ["v"], floor, s, known=True)
    assert a.tie_with == [] and h.tie_with == []     # 150 sigma apart on 8 points: not a tie


def test_the_noise_test_is_taken_with_many_units_when_the_noise_is_known():
    b_ev, a, _, floor = _setup()
    rb, ra = b_ev.runs[0], a.evaluation.runs[0]
    d = ra.model_force - rb.model_force
    args = (rb.unit_sse(), ra.unit_sse(), float(d @ d), 1.0)
    assert noise_test(*args).method == "paired t" and noise_test(*args).p > 0.01
    t = noise_test(*args, known=True)
    assert t.method == "noise" and t.p < 1e-12
