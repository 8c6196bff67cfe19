"""The daemon's liveness as others see it: `labjoint status`/`jobs` and `/rig` with
--no-daemon say "not running" once the daemon is gone, not its last published state;
`/rig` shows paths and process ids only to a caller with a token."""

from __future__ import annotations

import json
import socket


from labjoint.api.server import build, load_rig_config
from labjoint.cli.main import main
from labjoint.daemon import Daemon
from labjoint.daemon.liveness import liveness
from labjoint.daemon.queue import JobQueue
from test_api_helpers import AUTH, CONTROL, SHORT, sim_config_file, wait_for
from patience import http_client


def _status(capsys, cfg, data):
    assert main(["status", "--config", str(cfg), "--data", str(data), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_status_follows_the_daemon_and_rig_hides_paths_from_anonymous_callers(tmp_path, capsys):
    cfg = sim_config_file(tmp_path, api=f'control_tokens = ["{CONTROL}"]\n')
    data = tmp_path / "data"
    daemon = Daemon(load_rig_config(cfg), data, poll_s=0.05)
    daemon.start_in_thread()
    svc = None
    try:
        st = wait_for(lambda: _status(capsys, cfg, data), lambda s: s["daemon"]["running"])
        assert st["daemon"]["state"] == "idle" and st["daemon"]["heartbeat_age_s"] < 30
        svc = build(cfg, data_dir=data, port=0, daemon=False, log_level="warning", env={})
        sock = socket.socket()
        sock.bind(("127.0.0.1", 0))
        svc.start_in_thread(sock)
        wait_for(lambda: svc.server.started, bool, timeout=10)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}/api/v1"
        with http_client(url) as http:
            job = http.post("/plans", headers=AUTH, json={"plan": "dwell", "parameters": {
                "frequency_hz": 400, "amplitude_vpp": 2, **SHORT}}).json()
            wait_for(lambda: http.get(f"/plans/{job['id']}", headers=AUTH).json()["status"],
                     lambda s: s == "done", timeout=120)
            anon = http.get("/rig").json()["daemon"]
            mine = http.get("/rig", headers=AUTH).json()["daemon"]
            assert anon["running"] and not {"pid", "data_dir", "queue_db"} & set(anon)
            assert mine["pid"] and mine["data_dir"] == str(data)
            assert main(["jobs", "--config", str(cfg), "--data", str(data), "--json"]) == 0
            jobs = json.loads(capsys.readouterr().out)["jobs"]
            assert [j["id"] for j in jobs] == [job["id"]] and jobs[0]["status"] == "done"
            daemon.stop()
            gone = wait_for(lambda: http.get("/rig", headers=AUTH).json()["daemon"],
                            lambda d: d["state"] != "idle")     # its stop is seen at the next poll
            assert gone["state"] == "not running" and gone["running"] is False
            assert gone["last_state"] is not None
        st = _status(capsys, cfg, data)
        assert st["daemon"]["state"] == "not running" and st["jobs"]["done"] == 1
    finally:
        daemon.stop()
        if svc is not None:
            svc.stop()


def test_a_silent_daemon_is_not_responding_and_a_queue_never_served_is_not_running(tmp_path):
    from datetime import datetime, timedelta, timezone

    q = JobQueue(tmp_path / "queue.sqlite")
    assert liveness(q)["state"] == "not running" and liveness(q)["last_heartbeat"] is None
    (tmp_path / "queue.sqlite.lock").write_text("1\n")        # pid 1 is alive
    q.set_daemon_status({"state": "running"})
    later = datetime.now(timezone.utc) + timedelta(minutes=5)
    assert liveness(q, now=later)["state"] == "not responding"
    assert liveness(q)["state"] == "running"
