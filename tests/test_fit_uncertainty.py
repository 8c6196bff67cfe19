"""Fit uncertainty, validation split, warm start, multistart and result serialisation."""

from __future__ import annotations

import json

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.models import Model, ModelFitter, Parameters, RunData, nrmse
from labjoint.models.summary import period_shift_floor as noise_floor

FS = 25600.0


def sine(U, f, cycles):
    t = np.arange(int(round(cycles * FS / f))) / FS
    ph = np.mod(2 * np.pi * f * t, 2 * np.pi)
    return ph, U * np.sin(ph)


def jenkins_runs(n_runs, seed, c=0.0, f=200.0, cycles=6, k=2e7, fs_=40.0, noise=0.01):
    """Closed-form Jenkins loops (+ optional viscous c v) with force noise."""
    rng = np.random.default_rng(seed)
    runs = []
    for i in range(n_runs):
        U = (4e-6, 8e-6, 14e-6)[i % 3]
        ph, u = sine(U, f, cycles)
        lo, hi = u.min(), u.max()
        rising = (ph < np.pi / 2) | (ph >= 3 * np.pi / 2)
        F = np.where(rising, np.minimum(-fs_ + k * (u - lo), fs_), np.maximum(fs_ - k * (hi - u), -fs_))
        first = np.arange(u.size) <= np.argmax(u)
        F[first] = np.minimum(k * u[first], fs_)
        F = F + c * 2 * np.pi * f * U * np.cos(ph)
        F = F + rng.normal(0, noise * np.abs(F).max(), F.size)
        runs.append(RunData.from_arrays(u, F, FS, frequency_hz=f, steady=(int(FS / f), u.size),
                                        name=f"{f:.0f}Hz_{i}"))
    return runs


def test_standard_errors_shrink_like_one_over_root_n():
    few = ModelFitter("coulomb").fit(jenkins_runs(3, seed=10))
    many = ModelFitter("coulomb").fit(jenkins_runs(12, seed=11))
    for k in ("coulomb.k", "coulomb.f_s"):
        ratio = few.stderr_[k] / many.stderr_[k]
        assert 1.6 < ratio < 2.5, (k, ratio)          # 4x the data: ~2x smaller
    assert set(few.varied_) == {"coulomb.k", "coulomb.f_s"}
    C = few.correlation_
    np.testing.assert_allclose(C, C.T)
    np.testing.assert_allclose(np.diag(C), 1.0)
    assert abs(few.correlation("coulomb.k", "coulomb.f_s")) < 1


def test_validation_split_reports_held_out_error_like_seed000():
    runs = jenkins_runs(3, seed=20, f=200.0) + jenkins_runs(3, seed=21, f=400.0, cycles=12)
    fit_runs = [r for r in runs if r.frequency_hz == 200.0]
    val_runs = [r for r in runs if r.frequency_hz != 200.0]
    assert len(fit_runs) == 3 and len(val_runs) == 3
    good = ModelFitter("coulomb").fit(fit_runs, validation=val_runs)
    assert set(good.validation_run_nrmse_) == {r.name for r in val_runs}
    floor = noise_floor(val_runs)
    assert good.validation_nrmse_ < 1.3 * floor
    poor = ModelFitter("linear_stiffness+viscous").fit(fit_runs, validation=val_runs)
    assert poor.validation_nrmse_ > 5 * good.validation_nrmse_
    pooled, per = nrmse("coulomb", good.params_, val_runs)
    assert pooled == pytest.approx(good.validation_nrmse_) and per == good.validation_run_nrmse_


def test_warm_start_refit_with_one_extra_effect():
    runs = jenkins_runs(3, seed=30, c=300.0)
    base = ModelFitter("coulomb").fit(runs)
    richer = ModelFitter(Model.parse("coulomb") + "viscous").fit(runs, init=base)
    assert len(richer.start_costs_) == 1         # new parameter is linear: nothing to search
    assert richer.nrmse_ < 0.5 * base.nrmse_
    assert richer.params_["viscous.c"].value == pytest.approx(300.0, rel=0.05)
    assert richer.params_["coulomb.f_s"].value == pytest.approx(40.0, rel=0.02)


def test_multistart_auto_stops_at_the_noise_floor_and_fixed_count_runs_all():
    runs = jenkins_runs(3, seed=40)
    auto = ModelFitter("coulomb").fit(runs)
    assert len(auto.start_costs_) == 1 and auto.nrmse_ < 1.5 * noise_floor(runs)
    three = ModelFitter("coulomb", multistart=3, seed=1).fit(runs)
    assert len(three.start_costs_) == 3
    assert 0.5 * three.ssr_ == pytest.approx(min(three.start_costs_), rel=1e-9)


def test_bounds_hold_and_fixed_parameters_stay():
    runs = jenkins_runs(3, seed=50, c=-50.0)     # apparent negative damping
    p = Parameters()
    p.add("coulomb.f_s", 40.0, lower=0.0, vary=False)
    res = ModelFitter("coulomb+viscous", params=p).fit(runs)
    assert res.params_["viscous.c"].value == 0.0       # c >= 0 (vocabulary bound)
    assert res.params_["coulomb.f_s"].value == 40.0 and "coulomb.f_s" not in res.stderr_


def test_result_serialises_to_json_and_reloads_the_model():
    res = ModelFitter("coulomb").fit(jenkins_runs(3, seed=60))
    d = json.loads(json.dumps(res.to_dict()))
    assert d["model"] == "coulomb" and d["success"] is True and len(d["run_nrmse"]) == 3
    model, params = Model.from_dict(d)
    run = jenkins_runs(1, seed=61)[0]
    np.testing.assert_allclose(model.eval(params, run), res.model.eval(res.params_, run))
    assert "coulomb.f_s" in res.report()


def test_bad_fit_inputs_are_refused():
    with pytest.raises(InputError, match="RunData"):
        ModelFitter("coulomb").fit([np.zeros(3)])
    p = Parameters()
    p.add("iwan.K_T", 1.0)
    with pytest.raises(InputError, match="iwan.K_T"):
        ModelFitter("coulomb", params=p).fit(jenkins_runs(1, seed=0))
    with pytest.raises(InputError, match="multistart"):
        ModelFitter("coulomb", multistart=0).fit(jenkins_runs(1, seed=0))


def test_refit_adding_an_input_effect_starts_neutral_and_cannot_end_worse():
    runs = jenkins_runs(3, seed=70)
    base = ModelFitter("coulomb").fit(runs)
    more = ModelFitter("coulomb+backlash").fit(runs, init=base)
    assert more.nrmse_ <= base.nrmse_ * (1 + 1e-9)
    assert more.params_["backlash.gap"].value < 0.01 * 4e-6     # no gap in the data


def test_fitter_constructor_only_stores_settings():
    f = ModelFitter("coulomb", multistart=2, seed=5, max_nfev=10)
    assert set(vars(f)) == {"model", "multistart", "seed", "max_nfev", "params", "solve_linear", "method"}
    res = f.fit(jenkins_runs(1, seed=0))
    assert f.result_ is res
