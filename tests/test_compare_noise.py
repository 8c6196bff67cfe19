"""The noise floor: cycle-to-cycle scatter, not inflated by drift or a passing transient,
and equal to the NRMSE that noise alone leaves a perfect model."""

import numpy as np
import pytest

from labjoint.compare.metrics import evaluate
from labjoint.compare.measurement import noise_floor
from labjoint.compare.noise import scatter_variance
from labjoint.compare.runs import prepare_run, prepare_runs
from labjoint.models import Model
from test_compare_synth import FS, sweep, synth_run


def _cycles(n: int, per: float) -> list[np.ndarray]:
    """One group of n consecutive cycle bounds (fractional samples), starting at sample 1."""
    return [1.0 + np.arange(n + 1) * per]


def _periodic(t: np.ndarray, f: float) -> np.ndarray:
    w = 2 * np.pi * f
    return 50 * np.sin(w * t) + 8 * np.sin(3 * w * t + 0.4) + 3 * np.cos(2 * w * t) + 1.5 * np.sin(7 * w * t)


def test_scatter_recovers_white_noise_despite_a_slow_drift():
    f, sigma, n_cyc = 300.0, 0.4, 64
    per = FS / f
    t = np.arange(int(n_cyc * per) + 6) / FS
    rng = np.random.default_rng(1)
    drift = 1.0 + 0.15 * t / t[-1]                   # the loop grows 15 % over the record
    x = drift * _periodic(t, f) + sigma * rng.standard_normal(t.size)
    cyc = _cycles(n_cyc, per)
    var, n, windows = scatter_variance(x, cyc)
    assert np.sqrt(var) == pytest.approx(sigma, rel=0.05)
    # a plain scatter of each cycle about the mean cycle counts the drift as noise
    stack = np.array([x[int(a):int(a) + int(per)] for a in cyc[0][:-1]])
    naive = np.sqrt(np.mean((stack - stack.mean(axis=0)) ** 2))
    assert naive > 3 * sigma


def test_scatter_leaves_out_a_decaying_start_up_transient():
    f, sigma, n_cyc = 400.0, 0.3, 64
    per = FS / f
    t = np.arange(int(n_cyc * per) + 6) / FS
    rng = np.random.default_rng(2)
    ring = 20.0 * np.exp(-t / 0.02) * np.sin(2 * np.pi * 37.0 * t)   # a low rig mode, decaying
    x = _periodic(t, f) + ring + sigma * rng.standard_normal(t.size)
    var, _, windows = scatter_variance(x, _cycles(n_cyc, per))
    assert np.sqrt(var) == pytest.approx(sigma, rel=0.08)
    assert windows < n_cyc // 8                      # some windows were left out


def test_noise_floor_is_the_nrmse_of_the_true_model():
    k = 1e7
    runs = prepare_runs(sweep(k=k, c=50.0, noise_f=0.3, noise_u=3e-9, cycles=40))
    nf = noise_floor(runs)
    ev = evaluate(Model.parse("linear_stiffness+viscous"), {"linear_stiffness.k": k,
                                                             "viscous.c": 50.0}, runs)
    assert nf.nrmse == pytest.approx(ev.nrmse(), rel=0.06)
    # per run: sqrt(sigma_F^2 + k^2 sigma_u^2) relative to the run's rms force
    for r, rn in zip(runs, nf.runs):
        expect = np.hypot(0.3, k * 3e-9) / np.sqrt(np.mean(r.data.force[r.steady] ** 2))
        assert rn.nrmse == pytest.approx(expect, rel=0.1)


def test_noise_floor_of_a_noise_free_run_is_tiny():
    r = prepare_run(synth_run("q", 400.0, 5e-6, noise_f=0.0))
    assert noise_floor([r]).nrmse < 1e-6
