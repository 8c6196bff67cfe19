"""End to end through a real uvicorn on loopback with the acquisition daemon in the same
process on the simulated rig (``labjoint serve``'s default): submit plans, poll, fetch
runs, results, data slices and files; cancel, emergency stop, torque confirmation."""

from __future__ import annotations

import socket
import textwrap

import httpx
import numpy as np
import pytest

from labjoint.api import create_app, load_settings
from labjoint.api.server import build, load_rig_config
from labjoint.daemon import Daemon, JobQueue
from labjoint.storage import open_run
from test_api_helpers import CONTROL, SHORT, sim_config_file, wait_for
import patience
from patience import http_client

AUTH = {"Authorization": f"Bearer {CONTROL}"}
DONE = ("done", "failed", "cancelled", "aborted")


@pytest.fixture(scope="module")
def service(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("e2e")
    cfg = sim_config_file(tmp, api=f'control_tokens = ["{CONTROL}"]\n')
    svc = build(cfg, data_dir=tmp / "data", port=0, log_level="warning", env={})
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    svc.start_in_thread(sock)
    wait_for(lambda: svc.server.started, bool, timeout=10)
    url = f"http://127.0.0.1:{sock.getsockname()[1]}"
    with http_client(url + "/api/v1", headers=AUTH) as http:
        yield http, url, svc
    svc.stop()
    assert svc.daemon.status()["generator"]["output"] is False


def _plan(http, body, timeout=120):
    r = http.post("/plans", json=body)
    assert r.status_code == 202, r.text
    return wait_for(lambda: http.get(f"/plans/{r.json()['id']}").json(),
                    lambda j: j["status"] in DONE, timeout=timeout)


def test_service_binds_loopback_and_reports_the_simulated_rig(service):
    http, _, svc = service
    assert svc.settings.host == "127.0.0.1"
    health = http.get("/health").json()
    assert health["daemon"] == "embedded"
    rig = http.get("/rig").json()
    assert rig["backend"] == "sim" and rig["daemon"]["rig_backend"] == "sim"
    assert rig["daemon"]["generator"]["output"] is False


def test_amplitude_sweep_end_to_end(service, tmp_path):
    http, _, _ = service
    job = _plan(http, {"plan": "amplitude_sweep",
                       "parameters": {"amplitudes_vpp": [2, 6], "frequency_hz": 400,
                                      "torque_nm": 5, **SHORT}})
    assert job["status"] == "done" and len(job["runs"]) == 2, job
    listed = http.get("/runs", params={"plan": "amplitude_sweep", "vpp_min": 1.5,
                                       "order": "excitation_vpp"}).json()["items"]
    assert [r["name"] for r in listed if r["name"] in job["runs"]] == job["runs"]
    meta = http.get(f"/runs/{job['runs'][1]}").json()
    assert (meta["excitation_vpp"], meta["torque_nm"], meta["frequency_hz"]) == (6, 5, 400)
    assert meta["status"] == "complete" and meta["n_samples"] >= 20 * 10000 / 400

    r = http.post("/analyses", json={"runs": job["runs"]})
    result = wait_for(lambda: http.get(f"/analyses/{r.json()['id']}").json(),
                      lambda j: j["status"] != "queued" and j["status"] != "running")
    assert result["status"] == "complete"
    lo, hi = result["result"]["runs"]
    assert lo["frequency_hz"] == hi["frequency_hz"] == 400
    # below macro-slip the rig is nearly linear: response scales with excitation
    ratio_u = hi["displacement_amplitude_m"] / lo["displacement_amplitude_m"]
    assert ratio_u == pytest.approx(3, rel=0.15)
    assert hi["force_amplitude_n"] / lo["force_amplitude_n"] == pytest.approx(3, rel=0.15)
    assert hi["energy_loss_j"] > lo["energy_loss_j"]

    s = http.get(f"/runs/{job['runs'][1]}/data",
                 params={"channel": ["displacement", "force"], "max_points": 400}).json()
    assert s["decimated"] and all(len(x["values"]) <= 400 for x in s["series"])
    u = np.array(s["series"][0]["values"])
    # min/max decimation keeps the peaks: half peak-to-peak is the loop's U
    assert (u.max() - u.min()) / 2 == pytest.approx(hi["displacement_amplitude_m"], rel=0.1)

    f = http.get(f"/runs/{job['runs'][0]}/file")
    assert f.status_code == 200 and f.content[:8] == b"\x89HDF\r\n\x1a\n"
    copy = tmp_path / "copy.h5"
    copy.write_bytes(f.content)
    with open_run(copy) as rf:
        assert rf.name == job["runs"][0] and rf.status == "complete"
        assert rf.n_samples == http.get(f"/runs/{rf.name}").json()["n_samples"]


def test_readme_example_runs_against_the_service(service, monkeypatch, capsys):
    import labjoint.client as client
    http, url, _ = service
    code = textwrap.dedent(client.__doc__.split("::\n", 1)[1].split("\nEvery method")[0])
    code = code.replace("n_cycles=50", "**short")          # keep the simulation short
    monkeypatch.setenv("LABJOINT_API_URL", url)
    monkeypatch.setenv("LABJOINT_API_TOKEN", CONTROL)
    exec(compile(code, "README example", "exec"), {"short": SHORT})
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].split()[:3] == ["run", "Vpp", "U"]
    assert [ln.split()[1] for ln in lines[1:]] == ["1", "4", "8"]


def test_cancel_a_running_plan(service):
    http, _, _ = service
    r = http.post("/plans", json={"plan": "dwell", "parameters": {
        "frequency_hz": 400, "amplitude_vpp": 2, "n_cycles": 200_000}})
    jid = r.json()["id"]
    wait_for(lambda: http.get(f"/plans/{jid}").json()["status"], lambda s: s == "running")
    assert http.post(f"/plans/{jid}/cancel").json()["cancel_requested"] is True
    job = wait_for(lambda: http.get(f"/plans/{jid}").json(), lambda j: j["status"] in DONE)
    assert job["status"] == "cancelled"
    assert http.get("/rig").json()["daemon"]["generator"]["output"] is False
    assert http.post(f"/plans/{jid}/cancel").status_code == 409


def test_emergency_stop_aborts_and_holds_the_queue(service):
    http, _, _ = service
    r = http.post("/plans", json={"plan": "dwell", "parameters": {
        "frequency_hz": 400, "amplitude_vpp": 2, "n_cycles": 200_000}})
    jid = r.json()["id"]
    wait_for(lambda: http.get(f"/plans/{jid}").json()["status"], lambda s: s == "running")
    assert http.post("/estop", json={"reason": "e2e"}).json()["estop"] == "e2e"
    job = wait_for(lambda: http.get(f"/plans/{jid}").json(), lambda j: j["status"] in DONE)
    assert job["status"] == "aborted"
    rig = http.get("/rig").json()
    assert rig["estop"] == "e2e" and rig["daemon"]["generator"]["output"] is False
    held = http.post("/plans", json={"plan": "dwell", "parameters": {
        "frequency_hz": 400, "amplitude_vpp": 2, **SHORT}}).json()
    assert http.get(f"/plans/{held['id']}").json()["status"] == "held"
    assert http.post(f"/plans/{held['id']}/resume").status_code == 409     # still latched
    http.post("/estop/clear")
    import time
    time.sleep(0.5)
    assert http.get(f"/plans/{held['id']}").json()["status"] == "held"   # nothing by itself
    assert http.post(f"/plans/{held['id']}/resume").json()["status"] == "queued"
    job = wait_for(lambda: http.get(f"/plans/{held['id']}").json(), lambda j: j["status"] in DONE)
    assert job["status"] == "done"


def test_torque_change_waits_for_the_operator(tmp_path):
    """With operator torque confirmation (the real rig's behaviour, forced on the
    simulator) a torque series pauses in 'waiting_torque' until POST .../torque."""
    from test_api_helpers import live_server
    cfg = sim_config_file(tmp_path)
    data = tmp_path / "data"
    daemon = Daemon(load_rig_config(cfg), data, poll_s=0.05, operator_torque=True)
    daemon.start_in_thread()
    try:
        settings = load_settings(data, cfg, env={"LABJOINT_API_TOKEN": CONTROL})
        app = create_app(settings, daemon=daemon, queue=JobQueue(data / "queue.sqlite"))
        with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as http:
            r = http.post("/plans", json={"plan": "torque_series", "parameters": {
                "torques_nm": [3, 8], "frequency_hz": 400, "amplitude_vpp": 4, **SHORT}})
            jid = r.json()["id"]
            for torque in (3, 8):
                job = wait_for(lambda: http.get(f"/plans/{jid}").json(),
                               lambda j: j["status"] == "waiting_torque", timeout=60)
                assert job["waiting_for"]["torque_nm"] == torque
                r = http.post(f"/plans/{jid}/torque", json={"torque_nm": torque})
                assert r.json()["status"] == "running"
            job = wait_for(lambda: http.get(f"/plans/{jid}").json(), lambda j: j["status"] in DONE)
            assert job["status"] == "done" and len(job["runs"]) == 2
            torques = [http.get(f"/runs/{n}").json()["torque_nm"] for n in job["runs"]]
            assert torques == [3, 8]
            assert http.post(f"/plans/{jid}/torque", json={"torque_nm": 5}).status_code == 409
    finally:
        daemon.stop()


@pytest.mark.slow        # end to end, 40-120 s on a busy machine (issue 31)
def test_serve_runs_until_sigterm_and_leaves_the_output_off(tmp_path):
    """``serve()`` as ``labjoint serve`` runs it: its own process, loopback, a session
    control token printed when none is configured, clean stop on SIGTERM."""
    import signal
    import subprocess
    import sys
    cfg = sim_config_file(tmp_path)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {k: v for k, v in __import__("os").environ.items() if not k.startswith("LABJOINT_API")}
    code = (f"from labjoint.api.server import serve; serve({str(cfg)!r}, port={port}, "
            f"data_dir={str(tmp_path / 'data')!r}, log_level='warning')")
    proc = subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.PIPE, text=True,
                            env=env)
    try:
        url = f"http://127.0.0.1:{port}/api/v1"
        health = wait_for(lambda: _try_get(url + "/health"), lambda r: r is not None, timeout=30)
        assert health["daemon"] == "embedded"
        assert httpx.post(url + "/estop/clear", timeout=patience.HTTP_TIMEOUT_S).status_code == 401
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=patience.s(30))
    # uvicorn re-raises the SIGTERM after its graceful shutdown (a clean stop for systemd)
    assert proc.returncode in (0, -signal.SIGTERM), err
    token = [ln for ln in err.splitlines() if "control token" in ln][0].rsplit(" ", 1)[1]
    assert len(token) >= 24
    assert f"http://127.0.0.1:{port}" in err
    q = JobQueue(tmp_path / "data" / "queue.sqlite").daemon_status()
    assert q["state"] == "stopped" and q["generator"]["output"] is False
    assert q["output_off_confirmed"] is True


def _try_get(url):
    try:
        return httpx.get(url, timeout=1).json()
    except httpx.HTTPError:
        return None


def test_no_daemon_mode_attaches_to_a_separate_daemon_through_the_queue(tmp_path):
    """``labjoint serve --no-daemon``: the API only writes the queue; a daemon started
    on its own over the same data directory runs the plan and publishes its status."""
    cfg = sim_config_file(tmp_path, api=f'control_tokens = ["{CONTROL}"]\n')
    data = tmp_path / "data"
    daemon = Daemon(load_rig_config(cfg), data, poll_s=0.05)
    daemon.start_in_thread()
    try:
        svc = build(cfg, data_dir=data, port=0, daemon=False, log_level="warning", env={})
        assert svc.daemon is None and svc.generated_token is None
        sock = socket.socket()
        sock.bind(("127.0.0.1", 0))
        svc.start_in_thread(sock)
        wait_for(lambda: svc.server.started, bool, timeout=10)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}/api/v1"
        with http_client(url, headers=AUTH) as http:
            assert http.get("/health").json()["daemon"] == "queue"
            job = _plan(http, {"plan": "dwell", "parameters": {
                "frequency_hz": 400, "amplitude_vpp": 3, **SHORT}})
            assert job["status"] == "done" and len(job["runs"]) == 1
            assert job["worker"] == daemon.worker_id
            rig = http.get("/rig").json()
            assert rig["mode"] == "queue" and rig["daemon"]["state"] == "idle"
            assert http.get(f"/runs/{job['runs'][0]}").json()["excitation_vpp"] == 3
        svc.stop()
        assert daemon.status()["state"] == "idle"      # the API's stop leaves the daemon alone
    finally:
        daemon.stop()
