"""Reprocess in one process: results keyed by run, pipeline, options and version, with
provenance; a second reprocess does nothing, a changed version recomputes only its runs,
an interrupted one resumes, a bad or vanished run is reported by name.

The runs are of a known linear joint F = k u + c du/dt: the hysteresis loop (seed 002
Eq. 1) returns C = c and loop slope K = k, and a fit of linear_stiffness+viscous recovers
k and c per torque group."""

from __future__ import annotations

import json
import sqlite3

import numpy as np
import pytest

from labjoint import __version__
from labjoint.batch.pipelines import pipeline_version
from labjoint.batch.reprocess import SerialRunner, execute, plan_reprocess
from labjoint.cli.main import main
from labjoint.storage import Catalog, read_processed
from labjoint.storage.checksum import raw_sha256
from labjoint.storage.results import Results, options_hash
from test_api_helpers import write_linear_run
from test_storage_fixtures import write_run

CASES = {"lin_a": (3e-6, 8e6, 300.0, 5.0), "lin_b": (6e-6, 1.2e7, 800.0, 5.0),
         "lin_c": (4e-6, 1e7, 500.0, 10.0)}          # U, k, c, torque


@pytest.fixture()
def lab(tmp_path):
    cat = Catalog(tmp_path / "catalog.sqlite")
    for name, (u, k, c, t) in CASES.items():
        write_linear_run(tmp_path, cat, name, amp_m=u, k=k, c=c, n=6000, torque_nm=t)
    return tmp_path, cat


def _reprocess(cat, pipeline="analyze", options=None, **kw):
    res = Results(cat)
    plan = plan_reprocess(res, cat.query(), pipeline, options or {"force": "joint"}, **kw)
    return plan, execute(plan, SerialRunner(), res)


def test_results_carry_the_physics_and_the_provenance(lab):
    d, cat = lab
    shas = {n: raw_sha256(d / f"{n}.h5") for n in CASES}
    plan, rep = _reprocess(cat)
    assert (rep["computed"], rep["skipped"], rep["failed"]) == (3, 0, 0)
    by = {r["run"]: r for r in rep["runs"]}
    res = Results(cat)
    for name, (u, k, c, _) in CASES.items():
        s = by[name]["summary"]
        assert s["damping_ns_per_m"] == pytest.approx(c, rel=0.01)
        assert s["stiffness_n_per_m"] == pytest.approx(k, rel=0.01)
        arrays, attrs = read_processed(d / f"{name}.h5", "loop")      # stored with the run
        assert np.mean(arrays["damping"][arrays["steady"] == 1]) == pytest.approx(c, rel=0.01)
        row = res.get(name, "analyze", options_hash({"force": "joint"}))
        assert row.status == "complete" and row.version == pipeline_version("analyze")
        assert row.labjoint_version == __version__ and row.options == {"force": "joint"}
        # the measurement's checksum, unchanged by the result now stored in the file
        assert row.input_sha256 == shas[name] == raw_sha256(d / f"{name}.h5")
        assert row.summary["damping_ns_per_m"] == pytest.approx(c, rel=0.01)


def test_second_reprocess_does_nothing_and_a_new_version_recomputes_only_its_runs(lab):
    d, cat = lab
    _reprocess(cat)
    plan, rep = _reprocess(cat)
    assert plan.tasks == [] and rep["skipped"] == 3 and rep["computed"] == 0
    with sqlite3.connect(cat.db_path) as con:       # lin_b's result is of an older version
        con.execute("UPDATE results SET version = 'analyze-old' WHERE run = 'lin_b'")
    plan, rep = _reprocess(cat)
    assert [t.key for t in plan.tasks] == ["lin_b"]
    assert {r["run"]: r["status"] for r in rep["runs"]} == {
        "lin_a": "skipped", "lin_b": "computed", "lin_c": "skipped"}
    other = _reprocess(cat, options={"force": "reference"})[1]     # other options: own key
    assert other["computed"] == 3


def test_an_interrupted_reprocess_resumes_where_it_stopped(lab):
    d, cat = lab
    res = Results(cat)
    plan = plan_reprocess(res, cat.query(), "analyze", {})

    def stop(done, total, note):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        execute(plan, SerialRunner(), res, stop)
    rows = res.of("analyze", options_hash({}))
    assert len(rows) == 1 and list(rows.values())[0][0] == "complete"
    again = plan_reprocess(res, cat.query(), "analyze", {})
    assert len(again.tasks) == 2 and [s["run"] for s in again.skipped] == list(rows)


def test_a_bad_run_and_a_vanished_file_are_named_and_the_others_go_on(lab):
    d, cat = lab
    write_run(d, "noise", np.random.default_rng(1).normal(size=(4, 3000)), catalog=cat)
    (d / "lin_c.h5").unlink()
    plan, rep = _reprocess(cat)
    by = {r["run"]: r for r in rep["runs"]}
    assert by["lin_a"]["status"] == by["lin_b"]["status"] == "computed"
    # random noise is no steady sine: not what analyze handles (issue 33 item 13)
    assert by["noise"]["status"] == "not_applicable" and "not a steady sine" in by["noise"]["error"]
    assert by["lin_c"]["status"] == "failed" and "disappeared" in by["lin_c"]["error"]
    row = Results(cat).get("noise", "analyze", options_hash({"force": "joint"}))
    assert row.status == "failed" and row.error == by["noise"]["error"]   # never complete
    assert row.summary == {"not_applicable": True}
    assert rep["failed"] == 1 and rep["not_applicable"] == 1 and rep["computed"] == 2


def test_fit_sweep_one_group_per_torque_recovers_each_groups_joint(lab):
    d, cat = lab
    write_linear_run(d, cat, "lin_d", amp_m=7e-6, k=1e7, c=500.0, n=6000, torque_nm=10.0)
    plan, rep = _reprocess(cat, "fit", {"model": "linear_stiffness+viscous"},
                           group_by="torque_nm")
    assert sorted(t.key for t in plan.tasks) == ["torque_nm=10.0", "torque_nm=5.0"]
    by = {r["run"]: r for r in rep["runs"]}
    assert by["lin_a"]["group"] == "torque_nm=5.0"
    p10 = by["lin_c"]["summary"]["parameters"]
    assert p10["linear_stiffness.k"] == pytest.approx(1e7, rel=1e-3)
    assert p10["viscous.c"] == pytest.approx(500.0, rel=1e-3)
    assert by["lin_d"]["summary"] == by["lin_c"]["summary"]
    arrays, attrs = read_processed(d / "lin_d.h5", f"fit_{plan.tasks[0].options_hash[:8]}"
                                   if plan.tasks[0].key == "torque_nm=10.0"
                                   else f"fit_{plan.tasks[1].options_hash[:8]}")
    assert json.loads(attrs["runs"]) == ["lin_c", "lin_d"]
    assert _reprocess(cat, "fit", {"model": "linear_stiffness+viscous"},
                      group_by="torque_nm")[0].tasks == []


def test_cli_json_and_the_runs_filters(lab, capsys):
    d, cat = lab
    argv = ["reprocess", "--data-dir", str(d), "--pipeline", "analyze", "--scheduler", "none",
            "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) >= {"computed", "skipped", "failed", "runs"} and out["computed"] == 3
    version = out["version"]
    assert main(argv) == 0 and json.loads(capsys.readouterr().out)["skipped"] == 3
    with sqlite3.connect(cat.db_path) as con:
        con.execute("UPDATE results SET version = 'analyze-old' WHERE run = 'lin_a'")
    assert main(["runs", "--data", str(d), "--has-result", version, "--json"]) == 0
    assert [r["name"] for r in json.loads(capsys.readouterr().out)["runs"]] == ["lin_b", "lin_c"]
    assert main(["runs", "--data", str(d), "--stale", "--json"]) == 0
    stale = json.loads(capsys.readouterr().out)["runs"]
    assert [r["name"] for r in stale] == ["lin_a"] and stale[0]["results"][0]["stale"]


def test_cli_a_query_matching_nothing_and_a_missing_model_are_one_line_errors(lab, capsys):
    d, _ = lab
    assert main(["reprocess", "--data-dir", str(d), "--pipeline", "analyze", "--torque", "99",
                 "--scheduler", "none"]) == 2
    assert "matches no runs" in capsys.readouterr().err
    assert main(["reprocess", "--data-dir", str(d), "--pipeline", "diagnose",
                 "--scheduler", "none"]) == 2
    assert "--model" in capsys.readouterr().err


def test_cli_a_failed_run_exits_non_zero_naming_it(lab, capsys):
    d, cat = lab
    (d / "lin_b.h5").unlink()
    code = main(["reprocess", "--data-dir", str(d), "--pipeline", "analyze", "--scheduler",
                 "none", "--json"])
    cap = capsys.readouterr()
    assert code == 2 and "run lin_b" in cap.err and "disappeared" in cap.err
    assert json.loads(cap.out)["computed"] == 2


def test_a_task_planned_for_other_code_is_refused_not_mislabelled(lab):
    """A worker whose pipeline version differs (another labjoint installed) refuses."""
    from dataclasses import replace

    from labjoint.batch.tasks import run_task

    d, cat = lab
    plan = plan_reprocess(Results(cat), cat.query(), "analyze", {})
    out = run_task(replace(plan.tasks[0], version="analyze-0000000000000000"))
    assert out["status"] == "failed" and "install the same labjoint" in out["error"]
    assert read_processed_or_none(d / "lin_a.h5") is None          # nothing written


def read_processed_or_none(path):
    from labjoint.errors import InputError
    try:
        return read_processed(path, "loop")
    except (InputError, KeyError):
        return None
