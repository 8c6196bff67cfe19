"""The record kind: fit, noise floor and diagnosis along a record under any excitation.

Synthetic records with known parameters: the displacement is a multisine (periodic) or a
band-limited random signal (not periodic), its derivatives exact (from its spectrum), the
force the vocabulary law along that history (the models layer) plus Gaussian noise.
"""

import numpy as np
import pytest

from labjoint.compare import diagnose_report, fit_report
from labjoint.compare.kinds import kind_of, prepare
from labjoint.compare.kinds.record import RecordMeasurement, difference_variance, period_scatter
from labjoint.compare.prepared import PreparedRun
from labjoint.errors import InputError
from labjoint.models import Model, ModelInputs
from labjoint.storage import Run
from test_compare_synth import synth_run

FS = 10_000.0
TRUE = {"linear_stiffness.k": 2e6, "viscous.c": 200.0, "coulomb.k": 5e6, "coulomb.f_s": 10.0}
NOISE_F = 0.01


def _spectrum_signal(n, lines, rng, rms):
    """u, v, a (exactly periodic over n samples) with random-phase lines at indices ``lines``."""
    spec = np.zeros(n // 2 + 1, complex)
    spec[lines] = np.exp(2j * np.pi * rng.random(len(lines)))
    w = 2 * np.pi * np.fft.rfftfreq(n, 1 / FS)
    u = np.fft.irfft(spec, n)
    scale = rms / np.std(u)
    return [scale * np.fft.irfft(spec * (1j * w) ** d, n) for d in range(3)]


def record(expr="linear_stiffness+viscous+coulomb", params=TRUE, periodic=True, seed=1,
           rms=5e-6, name="rec", noise_f=NOISE_F):
    rng = np.random.default_rng(seed)
    if periodic:
        period = 2000                               # 0.2 s: lines every 5 Hz
        u, v, a = (np.tile(x, 8) for x in _spectrum_signal(period, np.arange(2, 61), rng, rms))
    else:                                           # 10-300 Hz random, cropped: not periodic
        n = 1 << 16
        f = np.fft.rfftfreq(n, 1 / FS)
        lines = np.flatnonzero((f >= 10) & (f <= 300))
        full = _spectrum_signal(n, lines, rng, rms)
        u, v, a = (x[20_000:44_000] for x in full)
    F = Model.parse(expr).eval(params, ModelInputs(u, v, a, FS))
    F = F + noise_f * rng.standard_normal(F.size)
    t = np.arange(u.size) / FS
    return Run(name, t, u, F, {"sample_rate_hz": FS})


def test_noise_estimators_recover_white_noise_on_a_smooth_signal():
    rng = np.random.default_rng(0)
    t = np.arange(40_000) / FS
    smooth = np.sin(2 * np.pi * 37 * t) + 0.3 * np.sin(2 * np.pi * 210 * t + 1)
    x = smooth + 0.01 * rng.standard_normal(t.size)
    assert np.sqrt(difference_variance(x)) == pytest.approx(0.01, rel=0.05)
    per = FS / 1.0                                   # the smooth signal repeats every second
    bounds = 1.0 + per * np.arange(4)
    assert np.sqrt(period_scatter(x, bounds)) == pytest.approx(0.01, rel=0.05)


def test_a_multisine_record_is_judged_along_its_history_and_the_fit_recovers_the_law():
    m = prepare([record()])[0]
    assert isinstance(m, RecordMeasurement) and m.excitation.kind == "multisine"
    assert m.bounds is not None and m.spans.shape[0] >= 6          # whole periods as units
    noise = m.noise()
    assert noise.force_std == pytest.approx(NOISE_F, rel=0.15)      # period-to-period scatter
    rep = fit_report([m], "linear_stiffness+viscous+coulomb")
    got = {k: p.value for k, p in rep.fit.params_.items()}
    for k, v in TRUE.items():
        assert got[k] == pytest.approx(v, rel=0.03), k
    assert rep.evaluation.nrmse() < 1.3 * rep.noise.nrmse


def test_a_random_record_gets_blocks_and_the_difference_method_noise_floor():
    smooth = prepare([record("linear_stiffness+viscous", periodic=False)])[0]
    assert smooth.noise().force_std == pytest.approx(NOISE_F, rel=0.1)
    m = prepare([record(periodic=False)])[0]
    assert m.excitation.kind == "random" and m.bounds is None
    assert m.spans.shape[0] >= 4
    # stick-slip kinks leak into the differences: the stated upper bound, not below the truth
    assert NOISE_F * 0.95 <= m.noise().force_std <= 1.6 * NOISE_F
    # the displacement's zero of a record that does not start at rest is its mean, off
    # the joint's own zero by a little: a spring turns that into a constant force
    rep = fit_report([m], "linear_stiffness+viscous+coulomb+offset")
    assert rep.fit.params_["linear_stiffness.k"].value == pytest.approx(2e6, rel=0.03)
    assert rep.fit.params_["coulomb.f_s"].value == pytest.approx(10.0, rel=0.03)
    assert rep.evaluation.nrmse() < 1.3 * rep.noise.nrmse
    d = rep.to_dict(full=True)
    assert d["kind"] == "record" and d["maps"]["by_line"] is None
    bands = np.asarray(d["maps"]["by_band"]["nrmse"])
    assert np.sqrt(np.sum(bands ** 2)) == pytest.approx(rep.evaluation.nrmse(), rel=1e-6)


def test_diagnose_on_one_record_splits_it_in_time_and_names_the_missing_damping():
    dg = diagnose_report([record()], "linear_stiffness+coulomb",
                         candidates="viscous,cubic_stiffness,offset,inertia")
    assert dg.fit_runs == ["rec[fit]"] and dg.validation_runs == ["rec[validation]"]
    assert not dg.adequate and dg.best is not None and dg.best.effect == "viscous"
    assert "loss-like" in dg.best.evidence
    assert dg.best.nrmse_after_validation < 1.5 * dg.noise_floor_validation
    d = dg.to_dict(full=True)
    lines = d["maps"]["by_line"]
    # the missing damping force is at the drive's own lines, not a distortion
    assert lines["excited"] > lines["not_excited"]


def test_auto_kind_judges_a_set_one_way_and_sine_refuses_a_multisine():
    sine = synth_run("s1", 100.0, 5e-6, cycles=40)
    assert isinstance(prepare([sine])[0], PreparedRun)
    both = prepare([sine, record()])
    assert {m.kind for m in both} == {"record"} and kind_of(both).name == "record"
    with pytest.raises(InputError, match="multisine"):
        prepare([record()], kind="sine")
    with pytest.raises(InputError, match="unknown kind"):
        prepare([sine], kind="spectral")
    with pytest.raises(InputError, match="measured modes"):
        prepare([sine], kind="modal")
    with pytest.raises(InputError, match="FRF sets inside a structure"):
        prepare([sine], kind="frf")
    with pytest.raises(InputError, match="mix kinds"):
        kind_of([prepare([sine])[0], both[1]])


def test_warm_up_is_left_unjudged_until_the_motion_has_reached_both_extremes():
    run = record()
    auto = prepare([run])[0]
    u = run.displacement
    lo, hi = np.percentile(u, [1, 99])
    first_both = max(np.argmax(u <= lo), np.argmax(u >= hi))
    assert auto.spans[0, 0] >= first_both
    none = prepare([run], warmup=0)[0]
    assert none.spans[0, 0] <= 1
    with pytest.raises(InputError, match="warmup"):
        prepare([run], warmup="soon")


@pytest.mark.parametrize("sigma", [2e-6, 1e-7])
def test_the_noise_of_a_few_periods_leaves_out_a_decaying_start_up_response(sigma):
    """An oscillator started from rest by a multisine: its free response still rings in
    the judged periods, which must not count as noise (at 1e-7 m the ringing left in the
    most settled pair had read 400x the noise)."""
    from labjoint.models.simulate import simulate
    fs, n = 750.0, 1024
    rng = np.random.default_rng(4)
    f = np.fft.rfftfreq(n, 1 / fs)
    spec = np.zeros(f.size, complex)
    sel = (f >= 5) & (f <= 150)
    spec[sel] = np.exp(2j * np.pi * rng.random(sel.sum()))
    F = np.tile(np.fft.irfft(spec, n), 4)
    F *= 50 / np.std(F)
    y = simulate("inertia+viscous+linear_stiffness",
                 {"inertia.m": 2.0, "viscous.c": 10.0, "linear_stiffness.k": 5e4}, F, fs)
    y = y + sigma * rng.standard_normal(y.size)
    m = prepare([Run("ring", np.arange(F.size) / fs, y, F, {"sample_rate_hz": fs})], kind="record")[0]
    assert m.bounds is not None and m.spans.shape[0] < 5        # the few-periods estimate
    # the most settled pair still holds a trace of the ringing (the scatter of all the
    # judged periods about their mean read 15x the noise)
    assert m.noise().displacement_std == pytest.approx(sigma, rel=0.25)


def test_hysteretic_candidates_that_tie_on_a_record_are_reported_as_a_tie():
    # the tie check compares the force each candidate adds on the judged samples; on a
    # record (not steady cycles) it had failed with an AttributeError
    dg = diagnose_report([record()], "linear_stiffness+viscous",
                         candidates="coulomb,iwan,richard_abbott")
    d = dg.to_dict()
    assert d["candidates"][0]["effect"] in ("coulomb", "iwan", "richard_abbott")
    assert any("cannot be told apart" in c.get("tie", {}).get("reason", "") for c in d["candidates"])
