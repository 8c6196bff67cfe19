"""Where a model fails: residual parts by harmonic, phase, quadrant, reversals, time; the
physics curves and the plain sentences built from them."""

import numpy as np
import pytest

from labjoint.compare.curves import mean_loops, physics_curves
from labjoint.compare.describe import failures
from labjoint.compare.metrics import evaluate
from labjoint.compare.measurement import noise_floor
from labjoint.compare.residuals import harmonic_parts, residual_maps
from labjoint.compare.runs import prepare_runs
from labjoint.models import Model
from test_compare_synth import FS, sweep


def _groups(n_cycles: int, per: float) -> list[np.ndarray]:
    return [1.0 + np.arange(n_cycles + 1) * per]


@pytest.mark.parametrize("kind", ["constant", "odd", "even", "drift"])
def test_harmonic_parts_put_each_shape_in_its_part(kind):
    f, n_cyc = 400.0, 32
    per = FS / f
    t = np.arange(int(n_cyc * per) + 6) / FS
    s = 2 * np.pi * f * (t - 1.0 / FS)               # phase 0 at the first bound
    x = {"constant": 2.0 + 0 * t, "odd": 2.0 * np.cos(3 * s + 0.5),
         "even": 2.0 * np.cos(2 * s), "drift": (t / t[-1] - 0.5) * 4.0 * np.cos(s)}[kind]
    p = harmonic_parts(x, _groups(n_cyc, per))
    total = sum(p[k] for k in ("constant", "odd", "even", "drift", "rest"))
    assert p[kind] > 0.95 * total
    ref = float(np.sum(x[1:1 + int(n_cyc * per)] ** 2))
    assert total == pytest.approx(ref, rel=0.03)
    if kind == "odd":
        assert np.argmax(p["per_harmonic"]) == 3
        assert p["phase_h"][2] == pytest.approx(0.5, abs=0.02)


def _maps(model: str, params: dict, **kw):
    runs = prepare_runs(sweep(**kw))
    ev = evaluate(Model.parse(model), params, runs)
    nf = noise_floor(runs)
    return ev, residual_maps(ev, nf.by_run()), physics_curves(ev), nf


def test_missing_viscous_loss_is_in_quadrature_at_mid_stroke_and_grows_with_frequency():
    ev, m, c, nf = _maps("linear_stiffness", {"linear_stiffness.k": 1e7}, c=200.0)
    assert m.harmonic["odd"] > 0.9 * m.nrmse                     # the fundamental, in quadrature
    assert m.reversal_ratio < 0.6                                 # e ~ velocity: zero at reversals
    # the signed mean residual of a cycle follows cos(2 pi s): + at 0 and 1, - at 0.5
    assert m.phase_mean[0] > 0 > m.phase_mean[len(m.phase_mean) // 2]
    grid = m.grid_nrmse
    assert np.all(np.diff(np.nanmean(grid, axis=1)) > 0)          # worse at higher frequency
    assert c.frequency_exponent["measured"] == pytest.approx(1.0, abs=0.05)
    for f, s in c.energy_slope["measured"].items():
        assert s == pytest.approx(2.0, abs=0.05)                  # viscous: W ~ U^2
    text = " ".join(x["text"] for x in failures(ev, m, c, nf.nrmse))
    assert "under-predicts dissipation by 100 % on average" in text


def test_a_rate_independent_loss_against_viscous_data_errs_with_frequency():
    """Coulomb friction tuned to the viscous loss at 400 Hz: too much below, too little above."""
    ev, m, c, nf = _maps("linear_stiffness+coulomb", {"linear_stiffness.k": 1e7, "coulomb.k": 1e7,
                                                      "coulomb.f_s": 2.0}, c=200.0, amps=(5e-6,))
    text = " ".join(x["text"] for x in failures(ev, m, c, nf.nrmse))
    assert "under-predicts dissipation at higher frequency and over-predicts it at lower" in text
    assert c.frequency_exponent["model"] == pytest.approx(0.0, abs=0.05)


def test_missing_cubic_stiffness_is_odd_harmonic_near_reversals():
    ev, m, c, nf = _maps("linear_stiffness", {"linear_stiffness.k": 1e7}, k3=2e16,
                         amps=(2e-6, 6e-6, 1.5e-5))
    assert m.per_harmonic[3] > 0.2 * m.nrmse
    assert m.reversal_ratio > 1.5
    text = " ".join(x["text"] for x in failures(ev, m, c, nf.nrmse))
    assert "under-predicts stiffness" in text and "higher amplitude" in text


def test_missing_offset_is_the_constant_part():
    ev, m, c, nf = _maps("linear_stiffness", {"linear_stiffness.k": 1e7}, F0=3.0)
    assert m.harmonic["constant"] > 0.9 * m.nrmse
    assert np.all(m.phase_mean > 0)
    text = " ".join(x["text"] for x in failures(ev, m, c, nf.nrmse))
    assert "constant force" in text


def test_a_drifting_loop_shows_as_drift_over_time():
    ev, m, c, nf = _maps("linear_stiffness", {"linear_stiffness.k": 1e7}, drift=0.2, cycles=40)
    assert m.harmonic["drift"] > 0.9 * m.nrmse
    per_cycle = next(iter(m.cycle_nrmse.values()))
    assert per_cycle[0] > 3 * per_cycle[len(per_cycle) // 2]      # bad at both ends, good mid-way


def test_true_model_is_at_the_noise_floor_and_says_so():
    ev, m, c, nf = _maps("linear_stiffness+viscous", {"linear_stiffness.k": 1e7, "viscous.c": 80.0},
                         c=80.0)
    found = failures(ev, m, c, nf.nrmse)
    assert len(found) == 1 and "no error beyond measurement noise" in found[0]["text"]


def test_mean_loops_put_measured_and_model_on_one_cycle():
    ev, *_ = _maps("linear_stiffness", {"linear_stiffness.k": 1e7}, c=200.0, freqs=(400.0,),
                   amps=(5e-6,))
    loop = next(iter(mean_loops(ev).values()))
    u, fm, fd = loop["displacement_m"], loop["force_measured_n"], loop["force_model_n"]
    assert u.size == fm.size == fd.size == 128
    assert u[32] == pytest.approx(5e-6, rel=0.01)                # a quarter cycle: the peak
    area_meas = np.sum(fm * np.roll(u, -1) - np.roll(fm, -1) * u) / 2
    assert abs(area_meas) > 0 and np.sum(fd * np.roll(u, -1) - np.roll(fd, -1) * u) == pytest.approx(0, abs=1e-3 * abs(area_meas))
