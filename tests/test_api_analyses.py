"""Analysis and model jobs through a real uvicorn, on runs of a known linear joint:
F = k u + c du/dt gives energy loss pi c omega U^2 per cycle (seed 002 Eq. 1 returns
C = c) and loop slope k."""

from __future__ import annotations

import math

import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.api.jobs import JobRecord, JobRunner, JobStore
from labjoint.storage import Catalog
from test_api_helpers import AUTH, CONTROL, live_server, wait_for, write_linear_run
import patience
from patience import http_client

FS, F = 20000.0, 100.0
CASES = {"lin_a": (3e-6, 8e6, 300.0), "lin_b": (6e-6, 1.2e7, 800.0)}   # U, k, c


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    d = tmp_path_factory.mktemp("an")
    cat = Catalog(d / "catalog.sqlite")
    for name, (u, k, c) in CASES.items():
        write_linear_run(d, cat, name, fs=FS, f=F, amp_m=u, k=k, c=c, n=8000)
    app = create_app(ApiSettings(data_dir=d, control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as http:
        yield http, d


def _finished(http, kind, job_id):
    path = f"/analyses/{job_id}" if kind == "analysis" else f"/models/jobs/{job_id}"
    return wait_for(lambda: http.get(path).json(),
                    lambda j: j["status"] in ("complete", "failed", "cancelled"), timeout=60)


def test_hysteresis_job_recovers_the_linear_joint(served):
    http, _ = served
    r = http.post("/analyses", json={"runs": list(CASES) + ["lin_a"], "method": "hysteresis"})
    assert r.status_code == 202 and r.json()["status"] in ("queued", "running")
    job = _finished(http, "analysis", r.json()["id"])
    assert job["status"] == "complete", job
    assert job["request"]["runs"] == list(CASES)          # duplicates dropped
    by = {x["run"]: x for x in job["result"]["runs"]}
    for name, (u, k, c) in CASES.items():
        x = by[name]
        assert x["damping_ns_per_m"] == pytest.approx(c, rel=0.01)
        assert x["stiffness_n_per_m"] == pytest.approx(k, rel=0.01)
        assert x["energy_loss_j"] == pytest.approx(math.pi * c * 2 * math.pi * F * u**2, rel=0.01)
        assert x["displacement_amplitude_m"] == pytest.approx(u, rel=0.01)
        assert x["frequency_hz"] == F and x["cycles"] >= 3
    listed = http.get("/analyses").json()["items"]
    assert job["id"] in [j["id"] for j in listed]


def test_both_methods_side_by_side(served):
    """Stick-slip boundary (seed 002 Eqs. 6-9) on the same linear runs: below macro-slip
    K = 2 K_t is the loop slope (Eq. 9) and W = 4 K_t sum u du ~ 2 K_t U^2 (Eq. 7, the
    right-endpoint sum a few % above), so C ~ K / (pi omega) (Eq. 8)."""
    http, _ = served
    r = http.post("/analyses", json={"runs": ["lin_a"], "method": "both",
                                     "options": {"friction_coefficient": 0.2}})
    job = _finished(http, "analysis", r.json()["id"])
    assert job["status"] == "complete", job
    row = job["result"]["runs"][0]
    u, k, c = CASES["lin_a"]
    omega = 2 * math.pi * F
    assert row["stickslip_stiffness_n_per_m"] == pytest.approx(k, rel=0.01)
    assert row["shear_stiffness_n_per_m"] == pytest.approx(k / 2, rel=0.01)
    assert row["stickslip_macro_slip_fraction"] == 0
    assert row["stickslip_energy_loss_j"] == pytest.approx(k * u**2, rel=0.05)
    assert row["stickslip_damping_ns_per_m"] == pytest.approx(k / (math.pi * omega), rel=0.05)
    c_loop, c_ss = row["damping_ns_per_m"], row["stickslip_damping_ns_per_m"]
    assert row["damping_diff_pct"] == pytest.approx((c_loop - c_ss) / c_loop * 100)


def test_stick_slip_needs_a_friction_coefficient(served):
    from labjoint.identify.identified import Identified, save_identified
    http, d = served
    r = http.post("/analyses", json={"runs": ["lin_b"], "method": "stick_slip"})
    assert r.status_code == 422 and "friction" in r.json()["error"]["message"]
    save_identified(d, Identified("friction_coefficient", 0.17, 0.01, "", "test", "Eq. 10"))
    r = http.post("/analyses", json={"runs": ["lin_b"], "method": "stick_slip"})
    job = _finished(http, "analysis", r.json()["id"])
    assert job["result"]["runs"][0]["friction_coefficient"] == 0.17


def test_a_run_that_cannot_be_analysed_gets_its_own_error(served):
    http, _ = served
    r = http.post("/analyses", json={"runs": ["lin_a"], "options": {"min_cycles": 1000}})
    job = _finished(http, "analysis", r.json()["id"])
    assert job["status"] == "complete"
    assert "1000" in job["result"]["runs"][0]["error"]


@pytest.mark.parametrize("body,status,word", [
    ({"runs": ["nope"]}, 404, "nope"),
    ({"runs": ["lin_a"], "options": {"cutoff_hz": -5}}, 422, "options.cutoff_hz"),
    ({"runs": ["lin_a"], "options": {"colour": "red"}}, 422, "options.colour"),
    ({"runs": []}, 422, "runs"),
    ({"runs": ["../lin_a"]}, 422, "runs"),
    # 1e-300 overflowed the stick-slip loads K_t u / (mu N) into a server error
    ({"runs": ["lin_a"], "method": "stick_slip", "options": {"friction_coefficient": 1e-300}},
     422, "friction_coefficient"),
])
def test_bad_analysis_requests(served, body, status, word):
    http, _ = served
    r = http.post("/analyses", json=body)
    assert r.status_code == status and word in r.text


@pytest.mark.parametrize("op,options,word", [
    ("fit", {"colour": "red"}, "options.colour"),
    ("fit", {"candidates": ["viscous"]}, "options.candidates"),      # a diagnose option
    ("diagnose", {"factor": -1}, "options.factor"),
    ("diagnose", {"alpha": 2}, "options.alpha"),
    ("diagnose", {"progress": 1}, "options.progress"),                 # the server's own
    ("ladder", {"seed": "x"}, "options.seed"),
    ("ladder", {"multistart": 0}, "options.multistart"),
    ("ladder", {"validate": ["../lin_a"]}, "options.validate"),
])
def test_bad_model_options_are_422_before_any_job(served, op, options, word):
    http, _ = served
    before = len(http.get("/models/jobs").json()["items"])
    r = http.post(f"/models/{op}", json={"runs": ["lin_a"], "model": "linear_stiffness",
                                         "options": options})
    assert r.status_code == 422 and word in r.json()["error"]["message"], r.text
    assert len(http.get("/models/jobs").json()["items"]) == before


def test_validation_runs_named_in_options_must_be_catalogued(served):
    http, _ = served
    r = http.post("/models/diagnose", json={"runs": ["lin_a"], "model": "linear_stiffness",
                                            "options": {"validate": ["no_such_run"]}})
    assert r.status_code == 404 and "no_such_run" in r.json()["error"]["message"]
    r = http.post("/models/fit", json={"runs": ["lin_a"], "model": "Linear Stiffness"})
    assert r.status_code == 422


def test_model_jobs_call_compare_with_the_run_files(served, monkeypatch):
    """The job plumbing, with a stand-in for labjoint.compare that really fits
    F = k u + c du/dt by least squares on the files it is handed."""
    import numpy as np

    import labjoint.compare as compare
    from labjoint.storage import read_run
    http, d = served
    calls = []

    class Result:
        def __init__(self, params):
            self.params = params

        def to_dict(self):
            return {"params": self.params}

    def fit(paths, model, **options):
        calls.append((paths, model, options))
        out = {}
        for p in paths:
            run = read_run(p)
            u, f = run.displacement, run.force
            v = np.gradient(u, 1 / run.sample_rate_hz)
            (k, c), *_ = np.linalg.lstsq(np.stack([u, v], axis=1), f, rcond=None)
            out[run.name] = {"k": k, "c": c}
        return Result(out)

    monkeypatch.setattr(compare, "fit", fit, raising=False)
    monkeypatch.setattr(compare, "ladder", fit, raising=False)
    r = http.post("/models/fit", json={"runs": ["lin_b"], "model": "linear_stiffness + viscous",
                                       "options": {"multistart": 2}})
    assert r.status_code == 202
    job = _finished(http, "model", r.json()["id"])
    assert job["status"] == "complete" and job["kind"] == "model_fit"
    u, k, c = CASES["lin_b"]
    assert job["result"]["params"]["lin_b"]["k"] == pytest.approx(k, rel=1e-3)
    assert job["result"]["params"]["lin_b"]["c"] == pytest.approx(c, rel=1e-2)
    paths, model, options = calls[0]
    assert paths == [str((d / "lin_b.h5").resolve())]
    progress = options.pop("progress")               # compare's messages reach the job
    assert callable(progress)
    assert model == "linear_stiffness+viscous" and options == {"multistart": 2}
    r = http.post("/models/ladder", json={"runs": ["lin_a"], "max_steps": 3,
                                          "options": {"validate": ["lin_b"]}})
    _finished(http, "model", r.json()["id"])
    calls[1][2].pop("progress")
    # a validation run named by the client reaches compare as its file in the data dir
    assert calls[1][2] == {"max_steps": 3, "validate": [str((d / "lin_b.h5").resolve())]}
    listed = http.get("/models/jobs", params={"status": "complete"}).json()["items"]
    assert {j["kind"] for j in listed} == {"model_fit", "model_ladder"}


def test_unknown_jobs_are_404(served):
    http, _ = served
    assert http.get("/analyses/deadbeef").status_code == 404
    assert http.get("/models/jobs/deadbeef").status_code == 404


def test_jobs_outlive_the_runner_and_unfinished_ones_fail_at_restart(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite")
    runner = JobRunner(store, workers=1)
    job = runner.submit("analysis", {"x": 3}, lambda req, progress: {"square": req["x"] ** 2})
    assert runner.wait(job.id, timeout=patience.s(10)).result == {"square": 9}
    runner.shutdown()
    store.put(JobRecord(id="left", kind="analysis", status="running", request={},
                        submitted_at="2024-01-01T00:00:00+00:00"))
    again = JobRunner(JobStore(tmp_path / "jobs.sqlite"))
    assert again.get(job.id).result == {"square": 9}
    left = again.get("left")
    assert left.status == "failed" and "restarted" in left.error["message"]
    again.shutdown()


def test_queued_jobs_can_be_cancelled_running_ones_not(tmp_path):
    import threading
    gate = threading.Event()
    runner = JobRunner(JobStore(tmp_path / "jobs.sqlite"), workers=1)
    first = runner.submit("analysis", {}, lambda req, p: {"ok": gate.wait(10)})
    second = runner.submit("analysis", {}, lambda req, p: {"ok": True})
    wait_for(lambda: runner.get(first.id).status, lambda s: s == "running", timeout=10)
    assert runner.cancel(second.id).status == "cancelled"
    assert runner.cancel(first.id).status == "running"
    gate.set()
    assert runner.wait(first.id, 10).status == "complete"
    assert runner.get(second.id).status == "cancelled"
    runner.shutdown()


def test_failures_are_recorded_not_raised(tmp_path):
    runner = JobRunner(JobStore(tmp_path / "jobs.sqlite"), workers=1)

    def boom(req, progress):
        raise RuntimeError("kaput")

    job = runner.wait(runner.submit("analysis", {}, boom).id, 10)
    assert job.status == "failed" and job.error["message"] == "RuntimeError: kaput"
    runner.shutdown()
