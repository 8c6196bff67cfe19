"""Model jobs (issue 17 item 3): an unknown effect is refused at submit, a running
diagnosis can be cancelled, and a quick fit does not wait behind a long diagnosis."""

from __future__ import annotations

import threading
import time

import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.api.jobs import JobRunner, JobStore
from labjoint.storage.catalog import Catalog
from test_api_helpers import AUTH, CONTROL, live_server, wait_for, write_linear_run
import patience
from patience import http_client


@pytest.fixture(scope="module")
def http(tmp_path_factory):
    data = tmp_path_factory.mktemp("jobs")
    cat = Catalog(data / "catalog.sqlite")
    for i, amp in enumerate((2e-6, 4e-6, 6e-6, 8e-6)):
        write_linear_run(data, cat, f"lin_{i}", amp_m=amp)
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as c:
        yield c


@pytest.mark.parametrize("body, field, word", [
    ({"model": "linear_stiffness+frictionn"}, "model", "frictionn"),
    ({"model": "linear_stiffness", "options": {"candidates": ["viscous", "gluey"]}},
     "options.candidates", "gluey"),
])
def test_an_unknown_effect_is_refused_at_submit_naming_it_and_the_vocabulary(http, body, field, word):
    r = http.post("/models/diagnose", json={"runs": ["lin_0", "lin_1"], **body})
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert word in err["message"] and "bouc_wen" in err["message"]
    assert err["details"]["field"] == field
    assert http.get("/models/jobs").json()["items"] == []


def test_model_requests_take_the_measurement_kind(http):
    r = http.post("/models/fit", json={"runs": ["lin_0", "lin_1"], "model": "linear_stiffness",
                                       "options": {"kind": "sine"}})
    assert r.status_code == 202, r.text
    job = wait_for(lambda: http.get(f"/models/jobs/{r.json()['id']}").json(),
                   lambda j: j["status"] in ("complete", "failed"))
    assert job["status"] == "complete" and job["result"]["kind"] == "sine"
    bad = http.post("/models/fit", json={"runs": ["lin_0"], "model": "linear_stiffness",
                                         "options": {"kind": "frf"}})
    assert bad.status_code == 422


def test_a_running_diagnosis_is_cancelled_at_its_next_step(http):
    r = http.post("/models/diagnose", json={"runs": ["lin_0", "lin_1", "lin_2", "lin_3"],
                                            "model": "linear_stiffness",
                                            "options": {"warm": False}})
    jid = r.json()["id"]
    wait_for(lambda: http.get(f"/models/jobs/{jid}").json()["status"], lambda s: s == "running")
    c = http.post(f"/models/jobs/{jid}/cancel")
    assert c.status_code == 200, c.text
    assert c.json()["cancel_requested"] is True or c.json()["status"] == "cancelled"
    job = wait_for(lambda: http.get(f"/models/jobs/{jid}").json(),
                   lambda j: j["status"] not in ("queued", "running"), timeout=120)
    assert job["status"] == "cancelled"
    assert http.post(f"/models/jobs/{jid}/cancel").status_code == 409


def test_a_short_job_does_not_wait_behind_a_long_one(tmp_path):
    runner = JobRunner(JobStore(tmp_path / "jobs.sqlite"), workers=1, long_workers=1)
    release = threading.Event()
    try:
        long = runner.submit("model_diagnose", {}, lambda req, progress: release.wait(30) and {},
                             long=True)
        quick = runner.submit("model_fit", {}, lambda req, progress: {"ok": 1})
        assert runner.wait(quick.id, timeout=patience.s(10)).status == "complete"
        assert runner.get(long.id).status == "running"
    finally:
        release.set()
        runner.shutdown()


def test_a_running_job_stops_at_its_next_progress_call(tmp_path):
    runner = JobRunner(JobStore(tmp_path / "jobs.sqlite"), workers=1)
    started = threading.Event()

    def work(req, progress):
        started.set()
        for i in range(10_000):
            progress(i / 10_000, f"step {i}")
            time.sleep(0.001)
        return {"finished": True}

    try:
        job = runner.submit("model_ladder", {}, work)
        assert started.wait(10)
        assert runner.cancel(job.id).cancel_requested
        assert runner.wait(job.id, timeout=patience.s(10)).status == "cancelled"
    finally:
        runner.shutdown()


def test_a_diagnosis_reports_progress_that_moves(http):
    """Issue 17 item 10: the job's progress grows while it works (it stayed at 0 until
    the end), never goes back, and is 1 when it is complete."""
    r = http.post("/models/diagnose", json={"runs": ["lin_0", "lin_1", "lin_2", "lin_3"],
                                            "model": "linear_stiffness",
                                            "options": {"warm": False, "n_jobs": 1,
                                                        "candidates": ["viscous", "coulomb",
                                                                       "cubic_stiffness"]}})
    assert r.status_code == 202, r.text
    jid, seen = r.json()["id"], []

    def poll() -> dict:
        j = http.get(f"/models/jobs/{jid}").json()
        seen.append((j["status"], j["progress"], j["message"]))
        return j
    job = wait_for(poll, lambda j: j["status"] not in ("queued", "running"), timeout=180,
                   poll=0.01)
    assert job["status"] == "complete", job["error"]
    running = [p for s, p, _ in seen if s == "running"]
    assert any(0 < p < 1 for p in running), seen[-5:]
    assert running == sorted(running)
    assert job["progress"] == 1.0
