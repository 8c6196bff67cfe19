"""The ladder: successive models until adequate, saved in the run files and read back."""

import json

import pytest

from labjoint.compare import ladder_runs, load_ladder, load_ladders
from labjoint.compare.ladders import prefixes
from labjoint.storage import import_csv, read_processed
from test_compare_synth import sweep, write_csv

FEW = "viscous,offset,cubic_stiffness,inertia"


@pytest.fixture(scope="module")
def run_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("ladder")
    paths = []
    for r in sweep(k=1e7, c=150.0, F0=2.0, noise_f=0.3, cycles=16):
        write_csv(d / f"{r.name}.csv", r)
        paths.append(import_csv(d / f"{r.name}.csv", d / "data"))
    return paths


def test_auto_ladder_adds_the_missing_effects_until_adequate_and_saves_itself(run_files):
    lad = ladder_runs(run_files, "linear_stiffness", candidates=FEW, n_jobs=1)
    json.dumps(lad, allow_nan=False)
    steps = lad["steps"]
    assert [s["added"] for s in steps][0] is None
    assert {s["added"] for s in steps[1:]} == {"viscous", "offset"}
    assert all(b["nrmse"] < a["nrmse"] for a, b in zip(steps, steps[1:]))
    assert lad["adequate"] and steps[-1]["nrmse"] <= 1.5 * lad["noise_floor"]
    assert set(steps[-1]) >= {"model", "added", "nrmse"}
    # saved in every run file, where the REST service and the web page read it
    assert sorted(lad["saved"]) == sorted(map(str, run_files))
    back = load_ladders(run_files[0])
    assert [x["key"] for x in back] == [lad["key"]]
    assert load_ladder(run_files[-1], lad["key"])["final_model"] == steps[-1]["model"]
    arrays, attrs = read_processed(run_files[0], f"model_ladder_{lad['key']}")
    assert arrays["nrmse"].tolist() == pytest.approx([s["nrmse"] for s in steps])


def test_max_steps_stops_early_and_says_why(run_files):
    lad = ladder_runs(run_files, "linear_stiffness", max_steps=1, candidates=FEW, n_jobs=1,
                      save=False)
    assert len(lad["steps"]) == 2 and not lad["adequate"]
    assert "max_steps" in lad["stop_reason"] and lad["saved"] == []


def test_manual_ladder_follows_the_expression(run_files):
    lad = ladder_runs(run_files, "linear_stiffness+viscous+offset", auto=False,
                      candidates=FEW, n_jobs=1, save=False)
    assert [s["model"] for s in lad["steps"]] == ["linear_stiffness", "linear_stiffness+viscous",
                                                   "linear_stiffness+viscous+offset"]
    assert [s["added"] for s in lad["steps"]] == [None, "viscous", "offset"]
    assert lad["adequate"]


def test_prefixes_skip_invalid_models():
    assert [m.expr for m in prefixes("wear+iwan+viscous")] == ["wear+iwan", "wear+iwan+viscous"]
