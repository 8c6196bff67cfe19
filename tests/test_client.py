"""labjoint.client against a real uvicorn (job queue without a daemon, runs of a known
linear joint): every call, errors as ApiError, pagination, download, results table."""

from __future__ import annotations

import math

import numpy as np
import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.client import ApiError, Client
from labjoint.daemon import JobQueue
from labjoint.storage import Catalog
from test_api_helpers import CONTROL, READ, linear_joint, live_server, write_linear_run
import patience

FS, F, U, K, C = 20000.0, 100.0, 4e-6, 9e6, 400.0
NAMES = [f"run_{i}" for i in range(5)]


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    d = tmp_path_factory.mktemp("client")
    cat = Catalog(d / "catalog.sqlite")
    for i, name in enumerate(NAMES):
        write_linear_run(d, cat, name, fs=FS, f=F, amp_m=U, k=K, c=C, n=6000, vpp=1.0 + i)
    app = create_app(ApiSettings(data_dir=d, control_tokens=[CONTROL], read_tokens=[READ]),
                     queue=JobQueue(d / "queue.sqlite"))
    with live_server(app) as url:
        yield url, d


@pytest.fixture()
def lab(served, monkeypatch):
    monkeypatch.setenv("LABJOINT_API_URL", served[0])
    monkeypatch.setenv("LABJOINT_API_TOKEN", CONTROL)
    with Client(timeout=patience.HTTP_TIMEOUT_S) as c:
        yield c


def test_health_and_rig(lab):
    assert lab.health()["status"] == "ok"
    assert lab.rig_status()["mode"] == "queue"


def test_runs_every_page_and_filters(lab):
    assert [r["name"] for r in lab.runs(limit=2, order="name")] == NAMES
    assert len(lab.runs(limit=2, all_pages=False)) == 2
    mid = lab.runs(vpp_min=2.5, vpp_max=4.5, order="name")
    assert [r["name"] for r in mid] == ["run_2", "run_3"]
    assert lab.run("run_4")["excitation_vpp"] == 5.0
    assert lab.channels("run_0")["n_samples"] == 6000


def test_data_slice_in_physical_units(lab):
    s = lab.data("run_1", channels=["displacement"], start=0, stop=100, unit="samples")
    _, u, _ = linear_joint(6000, FS, F, U, K, C)
    np.testing.assert_allclose(s["series"][0]["values"], u[:100], atol=1e-6 * U)


def test_download(lab, served, tmp_path):
    _, d = served
    p = lab.download("run_2", tmp_path)
    assert p == tmp_path / "run_2.h5" and p.read_bytes() == (d / "run_2.h5").read_bytes()
    q = lab.download("run_2", tmp_path / "copy.h5")
    assert q.read_bytes() == p.read_bytes()
    with pytest.raises(ApiError) as e:
        lab.download("nope", tmp_path)
    assert e.value.status == 404 and not (tmp_path / "nope.h5").exists()


def test_analyze_and_results_table(lab):
    result = lab.analyze(["run_0", "run_3"])
    rows = {r["run"]: r for r in result["runs"]}
    assert rows["run_0"]["damping_ns_per_m"] == pytest.approx(C, rel=0.01)
    table = lab.results_table(result).splitlines()
    assert table[0].split() == ["run", "Vpp", "U", "(um)", "F", "(N)", "W", "(mJ)", "C",
                                "(Ns/m)", "K", "(MN/m)", "cycles"]
    cells = table[1].split()
    assert cells[0] == "run_0" and float(cells[2]) == pytest.approx(U * 1e6, rel=0.01)
    assert float(cells[4]) == pytest.approx(math.pi * C * 2 * math.pi * F * U**2 * 1e3, rel=0.01)
    assert float(cells[6]) == pytest.approx(K * 1e-6, rel=0.01)


def test_loops_of_the_linear_joint_and_no_saved_ladder(lab):
    """F = k u + c du/dt: every steady loop is the ellipse of area pi c omega U^2 and
    slope k (seed 002 Eq. 1)."""
    body = lab.loops("run_1", points_per_cycle=64, max_cycles=4)
    assert len(body["cycles"]) == 4 and body["points_per_cycle"] == 64
    w = math.pi * C * 2 * math.pi * F * U**2
    for c in body["cycles"]:
        u, f = np.array(c["displacement_m"]), np.array(c["force_n"])
        assert u.size == f.size == 64
        assert c["energy_loss_j"] == pytest.approx(w, rel=0.01)
        assert c["stiffness_n_per_m"] == pytest.approx(K, rel=0.01)
        fit = np.polyfit(u, f, 1)[0]                          # the drawn loop's slope
        assert fit == pytest.approx(K, rel=0.01)
    assert lab.ladders("run_1") == []
    with pytest.raises(ApiError) as e:
        lab.loops("run_1", max_cycles=0)
    assert e.value.status == 422


def test_plans_through_the_client(lab):
    job = lab.submit_plan("dwell", frequency_hz=400, amplitude_vpp=2, n_cycles=5)
    assert job["status"] == "queued" and lab.plan(job["id"])["plan"]["amplitude_vpp"] == 2
    assert job["id"] in [j["id"] for j in lab.plans(status="queued")["items"]]
    with pytest.raises(ApiError) as e:
        lab.continue_torque(job["id"], 5.0)
    assert (e.value.status, e.value.code) == (409, "conflict")
    assert lab.cancel_plan(job["id"])["status"] == "cancelled"
    with pytest.raises(TimeoutError):
        lab.wait_plan(lab.submit_plan("dwell", frequency_hz=400, amplitude_vpp=2)["id"],
                      timeout=0.3, poll_s=0.1)       # no daemon: it stays queued
    assert lab.wait_plan(job["id"], timeout=1)["status"] == "cancelled"
    with pytest.raises(ApiError) as e:
        lab.submit_plan("dwell", frequency_hz=400)
    assert e.value.status == 422 and "amplitude_vpp" in e.value.message


def test_emergency_stop_and_clear(lab):
    assert lab.emergency_stop("client test")["estop"] == "client test"
    assert lab.clear_estop()["estop"] is None


def test_tokens_decide_what_a_client_may_do(served):
    url, _ = served
    with Client(url, token=READ, timeout=patience.HTTP_TIMEOUT_S) as reader:
        assert reader.runs(limit=1, all_pages=False)
        with pytest.raises(ApiError) as e:
            reader.emergency_stop()
        assert e.value.status == 403
    with Client(url, token="", timeout=patience.HTTP_TIMEOUT_S) as anonymous, pytest.raises(ApiError) as e:
        anonymous.submit_plan("dwell", frequency_hz=400, amplitude_vpp=1)
    assert e.value.status == 401 and "token" in str(e.value)
