"""Diagnose and ladder by simulation error: the missing effect of a Bouc-Wen oscillator
comes out hysteretic, adding it drops the simulation error to the noise."""

import json

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.compare.output_error import Prediction
from labjoint.compare.simulation_loop import (MIN_TEST_UNITS, diagnose_simulation,
                                              ladder_simulation, unit_sse)
from labjoint.models.simulate import simulate
from labjoint.storage import Run

FS = 750.0
N = 1024
LINEAR_EXPR = "inertia+viscous+linear_stiffness"
LINEAR = {"inertia.m": 2.0, "viscous.c": 10.0, "linear_stiffness.k": 5e4}
#: the Bouc-Wen benchmark's system (Noel and Schoukens 2016) in the vocabulary's terms
BW = {**LINEAR, "bouc_wen.k0": 5e4, "bouc_wen.alpha": 800.0, "bouc_wen.beta": -1100.0,
      "bouc_wen.n": 1.0}
NOISE = 1e-6


def _multisine(seed, periods):
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(N, 1 / FS)
    spec = np.where((f >= 5) & (f <= 150), np.exp(2j * np.pi * rng.random(f.size)), 0)
    u = np.fft.irfft(spec, N)
    return np.tile(u * 50.0 / np.std(u), periods)


def _record(expr, params, seed=1, periods=4):
    F = _multisine(seed, periods)
    y = simulate(expr, params, F, FS) + NOISE * np.random.default_rng(seed + 10).standard_normal(F.size)
    return Run(f"rec{seed}", np.arange(F.size) / FS, y, F, {"sample_rate_hz": FS})


@pytest.fixture(scope="module")
def bw_record():
    return _record(LINEAR_EXPR + "+bouc_wen", BW)


def test_the_missing_effect_of_a_bouc_wen_oscillator_is_hysteretic(bw_record):
    d = diagnose_simulation([bw_record], LINEAR_EXPR)
    assert not d.adequate and d.base.nrmse() > 20 * d.noise_floor
    assert d.best is not None and d.best.effect == "bouc_wen"
    # adding it drops the simulation error on the held-out last third to the noise
    assert d.best.fit.nrmse("validation") <= 1.5 * d.floor_validation
    assert d.best.fit.params["bouc_wen.beta"].value == pytest.approx(-1100.0, rel=0.05)
    out = d.to_dict()
    assert out["measurement"] == "record" and out["error"] == "simulation"
    assert {s["effect"] for s in out["skipped"]} >= {"iwan", "valanis"}   # not simulable
    assert any(f["where"].startswith("frequency") for f in out["failures"])


def test_a_linear_oscillator_with_the_linear_model_is_adequate():
    d = diagnose_simulation([_record(LINEAR_EXPR, LINEAR, seed=3)], LINEAR_EXPR,
                            candidates="cubic_stiffness,bouc_wen")
    assert d.adequate and d.best is None
    assert d.base.nrmse() <= 1.5 * d.noise_floor


def test_the_ladder_adds_the_hysteresis_and_stops_at_the_noise(bw_record):
    res = ladder_simulation([bw_record], LINEAR_EXPR, candidates=["bouc_wen", "coulomb",
                                                                 "cubic_stiffness"])
    steps = res["steps"]
    assert [s["added"] for s in steps] == [None, "bouc_wen"]
    assert res["adequate"] and steps[-1]["nrmse"] <= 1.5 * res["noise_floor"]
    assert steps[-1]["nrmse"] < steps[0]["nrmse"] / 50


def test_the_paired_test_gets_enough_units_from_few_periods():
    judged = np.ones(3000, bool)
    p = Prediction("r", np.zeros(3000), np.ones(3000), judged)
    sse = unit_sse([p], [np.array([[0, 1000], [1000, 2000], [2000, 3000]])])
    assert sse.size >= MIN_TEST_UNITS and sse.sum() == pytest.approx(3000.0)


def test_cli_diagnose_by_simulation_prints_the_contract(tmp_path, capsys, bw_record):
    r = bw_record
    path = tmp_path / "rec.csv"
    rows = "\n".join(f"{t!r},{y!r},{f!r}" for t, y, f in zip(r.time.tolist(),
                                                           r.displacement.tolist(), r.force.tolist()))
    path.write_text("time_s,displacement_m,force_N\n" + rows + "\n")
    assert main(["diagnose", str(path), "--model", LINEAR_EXPR, "--error", "simulation",
                 "--candidates", "bouc_wen,offset", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["error"] == "simulation" and res["candidates"][0]["effect"] == "bouc_wen"
    assert res["candidates"][0]["significant"] and not res["adequate"]
    assert main(["diagnose", str(path), "--model", LINEAR_EXPR, "--periodic", "--json"]) != 0
    assert "--periodic goes with --error simulation" in capsys.readouterr().err
