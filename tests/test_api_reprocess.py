"""Reprocess as a REST job through a real uvicorn: progress, the report, no work the second
time, cancellation, bad options answered before any job. Runs of the linear joint
F = k u + c du/dt (seed 002 Eq. 1 returns C = c and loop slope K = k)."""

from __future__ import annotations

import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.storage import Catalog
from labjoint.storage.results import Results
from test_api_helpers import AUTH, CONTROL, live_server, wait_for, write_linear_run
from patience import http_client

CASES = {"lin_a": (3e-6, 8e6, 300.0, 5.0), "lin_b": (6e-6, 1.2e7, 800.0, 5.0),
         "lin_c": (4e-6, 1e7, 500.0, 10.0), "lin_d": (7e-6, 1e7, 500.0, 10.0)}


@pytest.fixture()
def served(tmp_path):
    cat = Catalog(tmp_path / "catalog.sqlite")
    for name, (u, k, c, t) in CASES.items():
        write_linear_run(tmp_path, cat, name, amp_m=u, k=k, c=c, n=6000, torque_nm=t)
    app = create_app(ApiSettings(data_dir=tmp_path, control_tokens=[CONTROL],
                                 reprocess_scheduler="none"))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as http:
        yield http, cat


def _finished(http, job_id):
    return wait_for(lambda: http.get(f"/reprocess/{job_id}").json(),
                    lambda j: j["status"] in ("complete", "failed", "cancelled"), timeout=120)


def test_a_reprocess_job_reports_each_run_and_skips_current_results(served):
    http, _ = served
    r = http.post("/reprocess", json={"pipeline": "analyze", "query": {"torque_nm": 5.0}})
    assert r.status_code == 202, r.text
    job = _finished(http, r.json()["id"])
    assert job["status"] == "complete" and job["progress"] == 1.0, job
    rep = job["result"]
    assert rep["computed"] == 2 and rep["skipped"] == 0
    by = {x["run"]: x for x in rep["runs"]}
    for name in ("lin_a", "lin_b"):
        u, k, c, _ = CASES[name]
        assert by[name]["summary"]["damping_ns_per_m"] == pytest.approx(c, rel=0.01)
        assert by[name]["summary"]["stiffness_n_per_m"] == pytest.approx(k, rel=0.01)
    again = _finished(http, http.post("/reprocess", json={"pipeline": "analyze"}).json()["id"])
    assert (again["result"]["skipped"], again["result"]["computed"]) == (2, 2)
    assert job["id"] in [j["id"] for j in http.get("/reprocess").json()["items"]]


def test_a_running_reprocess_is_cancelled_between_tasks(served):
    http, cat = served
    body = {"pipeline": "diagnose", "group_by": "torque_nm",
            "options": {"model": "linear_stiffness", "candidates": "viscous,coulomb"}}
    job_id = http.post("/reprocess", json=body).json()["id"]
    wait_for(lambda: http.get(f"/reprocess/{job_id}").json(),
             lambda j: j["status"] != "queued", timeout=60)
    r = http.post(f"/reprocess/{job_id}/cancel")
    assert r.status_code == 200 and r.json()["cancel_requested"], r.text
    job = _finished(http, job_id)
    assert job["status"] == "cancelled"
    recorded = {run for run, (s, _) in _all_rows(cat).items() if s == "complete"}
    assert recorded in (set(), {"lin_a", "lin_b"}, {"lin_c", "lin_d"})   # one group at most


def _all_rows(cat):
    rows = {}
    for name, results in Results(cat).for_runs(CASES).items():
        for x in results:
            rows[name] = (x.status, x.version)
    return rows


def test_bad_options_and_an_empty_query_answer_422_naming_them(served):
    http, _ = served
    r = http.post("/reprocess", json={"pipeline": "analyze", "options": {"force": "left"}})
    assert r.status_code == 422 and "options.force" in r.text
    r = http.post("/reprocess", json={"pipeline": "fit"})
    assert r.status_code == 422 and "options.model" in r.text
    r = http.post("/reprocess", json={"pipeline": "analyze", "query": {"torque_nm": 99}})
    assert r.status_code == 422 and "matches no runs" in r.text


def _accelerometer_run(data_dir, cat, name: str = "accel_only"):
    """A run with a force and an accelerometer and no displacement sensor (an impact
    hammer test's channels): the loop pipeline does not apply to it."""
    import numpy as np

    from labjoint.documents import Block, RunStart, RunStop
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.writer import RunWriter
    fs, n = 20000.0, 6000
    t = np.arange(n) / fs
    volts = np.stack([np.sin(2 * np.pi * 100 * t), 0.5 * np.sin(2 * np.pi * 100 * t + 0.3)])
    chans = [ChannelSpec("force_ref", "force", "force", "N", 50.0),
             ChannelSpec("accel", "accelerometer", "acceleration", "m/s^2", 100.0)]
    w = RunWriter(data_dir, catalog=cat)
    w("start", RunStart(f"uid-{name}", name, chans, fs, {"frequency_hz": 100.0,
                                                         "torque_nm": 5.0, "plan": "dwell"}))
    w("block", Block(f"uid-{name}", 0, volts))
    w("stop", RunStop(f"uid-{name}", "complete", n_samples=n))


def test_runs_a_pipeline_does_not_handle_are_not_applicable_and_the_run_list_shows_results(
        served, tmp_path):
    """Issue 33 item 13: an accelerometer-only run is 'not applicable' to analyze, not a
    failure; GET /runs gives each run's latest loop result (W, C, K) or why it has none."""
    http, cat = served
    _accelerometer_run(tmp_path, cat)
    before = {r["name"]: r["result"] for r in http.get("/runs").json()["items"]}
    assert before and all(v is None for v in before.values())       # nothing analysed yet
    job = _finished(http, http.post("/reprocess", json={"pipeline": "analyze"}).json()["id"])
    rep = job["result"]
    assert (rep["computed"], rep["not_applicable"], rep["failed"]) == (4, 1, 0), rep
    by = {x["run"]: x for x in rep["runs"]}
    assert by["accel_only"]["status"] == "not_applicable"
    assert "no displacement channel: the responses are accel (acceleration)" in by["accel_only"]["error"]
    listed = {r["name"]: r["result"] for r in http.get("/runs").json()["items"]}
    for name, (u, k, c, _) in CASES.items():
        res = listed[name]
        assert res["status"] == "complete" and res["error"] is None
        assert res["damping_ns_per_m"] == pytest.approx(c, rel=0.01)
        assert res["stiffness_n_per_m"] == pytest.approx(k, rel=0.01)
        # W of the viscous part over one cycle: pi c omega U^2 (seed 002 Eq. 1)
        assert res["energy_loss_j"] == pytest.approx(3.141592653589793 * c * 2 * 3.141592653589793
                                                     * 100.0 * u ** 2, rel=0.02)
    assert listed["accel_only"]["status"] == "not_applicable"
    assert "no displacement channel: the responses are accel (acceleration)" in listed["accel_only"]["error"]
