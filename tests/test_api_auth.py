"""Tokens, the one error shape, request limits and the plan queue through a real uvicorn
(a queue without a daemon: plans are queued, never run)."""

from __future__ import annotations

import httpx
import pytest

from labjoint.api import ApiSettings, create_app, load_settings
from labjoint.daemon import JobQueue
from labjoint.errors import ConfigError
from test_api_helpers import AUTH, CONTROL, READ, READ_AUTH, live_server
from patience import http_client
import patience

DWELL = {"plan": "dwell", "parameters": {"frequency_hz": 400, "amplitude_vpp": 2, "n_cycles": 5}}


def _serve(tmp_path, **kw):
    settings = ApiSettings(data_dir=tmp_path, **kw)
    queue = JobQueue(tmp_path / "queue.sqlite")
    return live_server(create_app(settings, queue=queue)), queue


@pytest.fixture(scope="module")
def http(tmp_path_factory):
    server, _ = _serve(tmp_path_factory.mktemp("auth"), control_tokens=[CONTROL],
                       read_tokens=[READ])
    with server as url, http_client(url + "/api/v1") as client:
        yield client


def _err(r: httpx.Response, status: int) -> dict:
    assert r.status_code == status, r.text
    body = r.json()
    assert set(body) == {"error"} and set(body["error"]) == {"code", "message", "details"}
    assert body["error"]["message"]
    return body["error"]


WRITES = [
    ("POST", "/plans", DWELL), ("POST", "/estop/clear", None),
    ("POST", "/analyses", {"runs": ["x"]}), ("POST", "/models/fit", {"runs": ["x"]}),
    ("POST", "/plans/abc/cancel", None), ("POST", "/plans/abc/torque", {"torque_nm": 5}),
    ("POST", "/plans/abc/resume", None)]


@pytest.mark.parametrize("method,path,body", WRITES)
def test_write_endpoints_need_a_control_token(http, method, path, body):
    """(The emergency stop itself is the one exception, from loopback only:
    tests/test_estop_hold.py.)"""
    e = _err(http.request(method, path, json=body), 401)
    assert "token" in e["message"]
    wrong = {"Authorization": "Bearer wrong-token-xx"}
    e = _err(http.request(method, path, json=body, headers=wrong), 401)
    assert e["message"] == "unknown API token"
    e = _err(http.request(method, path, json=body, headers=READ_AUTH), 403)
    assert "read-only" in e["message"]


def test_a_token_sent_to_the_emergency_stop_is_still_checked(http):
    wrong = {"Authorization": "Bearer wrong-token-xx"}
    assert _err(http.post("/estop", json={}, headers=wrong), 401)["message"] == "unknown API token"
    assert "read-only" in _err(http.post("/estop", json={}, headers=READ_AUTH), 403)["message"]
    assert http.get("/rig").json()["estop"] is None


def test_missing_token_challenges_with_bearer(http):
    r = http.post("/plans", json=DWELL)
    assert r.headers["www-authenticate"] == "Bearer"


def test_reads_are_open_by_default_and_tokens_are_checked_if_sent(http):
    assert http.get("/runs").status_code == 200
    assert http.get("/runs", headers=READ_AUTH).status_code == 200
    _err(http.get("/runs", headers={"Authorization": "Bearer not-a-token"}), 401)


def test_read_tokens_when_config_requires_them(tmp_path):
    server, _ = _serve(tmp_path, control_tokens=[CONTROL], read_tokens=[READ],
                       read_requires_token=True)
    with server as url, http_client(url + "/api/v1") as c:
        _err(c.get("/runs"), 401)
        _err(c.get("/plans"), 401)
        assert c.get("/runs", headers=READ_AUTH).status_code == 200
        assert c.get("/runs", headers=AUTH).status_code == 200      # control implies read
        assert c.get("/health").status_code == 200                 # liveness stays open
        schema = httpx.get(url + "/openapi.json", timeout=patience.HTTP_TIMEOUT_S).json()
        assert schema["paths"]["/api/v1/runs"]["get"]["security"] == [{"bearer": []}]
        assert "security" not in schema["paths"]["/api/v1/health"]["get"]


def test_without_any_control_token_nothing_writes(tmp_path):
    server, queue = _serve(tmp_path)
    with server as url, http_client(url + "/api/v1") as c:
        e = _err(c.post("/plans", json=DWELL), 403)
        assert "LABJOINT_API_TOKEN" in e["message"]
        assert queue.list() == []


def test_openapi_marks_writes_secured_and_open_reads_unsecured(http):
    schema = httpx.get(http.base_url.join("/openapi.json"), timeout=patience.HTTP_TIMEOUT_S).json()
    for path, ops in schema["paths"].items():
        for method, op in ops.items():
            assert ("security" in op) == (method != "get"), (method, path)


def test_settings_from_config_and_environment(tmp_path):
    cfg = tmp_path / "rig.toml"
    cfg.write_text('[api]\ncontrol_tokens = ["file-control-1"]\nread_requires_token = true\n'
                   'max_request_bytes = 4096\n')
    s = load_settings(tmp_path, cfg, env={"LABJOINT_API_TOKEN": "env-control-1, env-control-2",
                                          "LABJOINT_API_READ_TOKEN": "env-read-1"})
    assert [s.scope_of(t) for t in ("file-control-1", "env-control-2", "env-read-1", "x")] == \
        ["control", "control", "read", None]
    assert s.read_requires_token and s.max_request_bytes == 4096 and s.host == "127.0.0.1"
    cfg.write_text('[api]\ncontrol_tokens = ["short"]\n')
    with pytest.raises(ConfigError, match="api.control_tokens"):
        load_settings(tmp_path, cfg, env={})
    cfg.write_text('[api]\nport = "eighty"\n')
    with pytest.raises(ConfigError, match="rig.toml.*api.port"):
        load_settings(tmp_path, cfg, env={})


def test_unknown_route_method_and_validation_errors_share_the_shape(http):
    assert _err(http.get("/nowhere"), 404)["code"] == "not_found"
    r = http.delete("/runs")
    _err(r, 405)
    assert "GET" in r.headers["allow"]
    e = _err(http.get("/runs", params={"limit": 0}), 422)
    assert e["details"][0]["loc"] == ["query", "limit"]
    e = _err(http.post("/plans", content=b"{not json",
                       headers={**AUTH, "content-type": "application/json"}), 422)
    assert e["code"] == "invalid_request"


def test_request_size_limit(tmp_path):
    server, _ = _serve(tmp_path, control_tokens=[CONTROL], max_request_bytes=2048)
    big = {"plan": "dwell", "parameters": {"frequency_hz": 400, "amplitude_vpp": 2},
           "submitted_by": "x" * 5000}
    with server as url, http_client(url + "/api/v1", headers=AUTH) as c:
        assert _err(c.post("/plans", json=big), 413)["code"] == "request_too_large"

        def chunks():                            # no Content-Length: counted as it streams
            for _ in range(10):
                yield b" " * 1024

        assert _err(c.post("/plans", content=chunks(),
                           headers={"content-type": "application/json"}), 413)["code"] \
            == "request_too_large"
        assert c.post("/plans", json={**big, "submitted_by": "ok"}).status_code == 202


def test_plan_queue_life_cycle(http):
    job = http.post("/plans", json=DWELL, headers=AUTH)
    assert job.status_code == 202
    job = job.json()
    assert job["status"] == "queued" and job["plan"]["plan"] == "dwell"
    assert job["plan"]["n_cycles"] == 5 and job["submitted_by"] == "api:control"
    assert http.get(f"/plans/{job['id']}").json()["id"] == job["id"]
    listed = http.get("/plans", params={"status": "queued"}).json()["items"]
    assert job["id"] in [j["id"] for j in listed]
    e = _err(http.post(f"/plans/{job['id']}/torque", json={"torque_nm": 5}, headers=AUTH), 409)
    assert "not waiting" in e["message"]
    assert http.post(f"/plans/{job['id']}/cancel", headers=AUTH).json()["status"] == "cancelled"
    _err(http.post(f"/plans/{job['id']}/cancel", headers=AUTH), 409)
    _err(http.get("/plans/0123abcd"), 404)
    _err(http.post("/plans/0123abcd/cancel", headers=AUTH), 404)


@pytest.mark.parametrize("body,field", [
    ({"plan": "dwell", "parameters": {"frequency_hz": -1, "amplitude_vpp": 2}}, "frequency_hz"),
    ({"plan": "dwell", "parameters": {"amplitude_vpp": 2}}, "frequency_hz"),
    ({"plan": "no_such_plan"}, "plan"),
    ({"plan": "dwell", "parameters": {"frequency_hz": 400, "amplitude_vpp": 2, "bogus": 1}},
     "bogus"),
])
def test_bad_plans_are_422_naming_the_parameter(http, body, field):
    e = _err(http.post("/plans", json=body, headers=AUTH), 422)
    assert field in e["message"] or field in str(e["details"])


def test_estop_through_the_queue(http):
    r = http.post("/estop", json={"reason": "test stop"}, headers=AUTH).json()
    assert r == {"estop": "test stop", "daemon": "queue"}
    assert http.get("/rig").json()["estop"] == "test stop"
    assert http.post("/estop/clear", headers=AUTH).json()["estop"] is None
    assert http.get("/rig").json()["estop"] is None


def test_plan_types_list_every_plan_with_defaults(http):
    types = {p["name"]: p for p in http.get("/plan-types").json()}
    assert {"dwell", "amplitude_sweep", "torque_series", "step_sine"} <= set(types)
    sweep = types["amplitude_sweep"]["parameters"]
    # seed 002 Table 3 levels
    assert sweep["amplitudes_vpp"]["default"] == [1.0, 4.0, 8.0, 12.0, 16.0, 20.0]
    assert types["dwell"]["parameters"]["frequency_hz"]["required"] is True


FOREIGN = "http://evil.example"


def test_a_foreign_web_page_cannot_press_the_emergency_stop_or_write(http):
    """Issue 33 item 16: a browser's no-cors POST from another page carries that page's
    Origin; token-less from loopback it used to stop the rig. Every state-changing call
    from a foreign origin is refused (403) whatever the token, before it acts."""
    port = str(http.base_url.port)
    for origin in (FOREIGN, f"http://127.0.0.1:{int(port) + 1}", "null",
                   f"http://localhost:{port}"):          # another name: another site's page
        r = http.post("/estop", json={"reason": "drive-by"}, headers={"Origin": origin})
        err = _err(r, 403)
        assert err["code"] == "foreign_origin" and "another origin" in err["message"], err
        assert http.get("/rig").json()["estop"] is None      # nothing was stopped
    # a no-cors form post (no JSON type) and a cross-site fetch without Origin: refused
    r = http.post("/estop", content=b"reason=x", headers={
        "Content-Type": "text/plain", "Sec-Fetch-Site": "cross-site"})
    assert _err(r, 403)["code"] == "foreign_origin"
    queued = http.get("/plans").json()["items"]
    for method, path, body in WRITES:                      # with the control token too
        r = http.request(method, path, json=body, headers={**AUTH, "Origin": FOREIGN})
        assert _err(r, 403)["code"] == "foreign_origin", (method, path)
    assert http.get("/plans").json()["items"] == queued    # nothing queued
    # reads from anywhere (CORS still keeps their answers from the page); own page writes
    assert http.get("/rig", headers={"Origin": FOREIGN}).status_code == 200
    for own in (f"http://127.0.0.1:{port}", f"HTTP://127.0.0.1:{port}",
                f"https://127.0.0.1:{port}"):                  # its page behind a TLS proxy
        r = http.post("/estop", json={"reason": "own page"}, headers={"Origin": own,
                                                                      "Sec-Fetch-Site": "same-origin"})
        assert r.status_code == 200 and http.get("/rig").json()["estop"] == "own page"
        assert http.post("/estop/clear", headers={**AUTH, "Origin": own}).status_code == 200


def test_an_allowed_origin_may_write(tmp_path):
    server, _ = _serve(tmp_path, control_tokens=[CONTROL], allowed_origins=["https://lab.example"])
    with server as url, httpx.Client(base_url=url + "/api/v1") as client:
        r = client.post("/estop", json={}, headers={"Origin": "https://lab.example:443"})
        assert r.status_code == 200, r.text
        assert client.post("/estop/clear", headers={**AUTH, "Origin": FOREIGN}).status_code == 403
