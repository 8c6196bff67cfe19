"""Schemathesis over the whole REST API, served as ``labjoint serve`` serves it (the daemon
on the simulated rig): generated requests for every operation and stateful sequences
(jobs submitted, then polled and cancelled by the ids they returned) never get a server
error, and every state-changing operation refuses a caller without the token (the
emergency stop from this machine excepted: the documented loopback exception).
Bounded example counts keep it to well under a minute."""

from __future__ import annotations

import socket

import httpx
import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from schemathesis.checks import not_a_server_error

from labjoint.api.server import build
from labjoint.storage import Catalog
from test_api_helpers import AUTH, CONTROL, sim_config_file, wait_for, write_linear_run
import patience
from patience import http_client

# schemathesis's own strategies draw from the `random` module, which Hypothesis flags now
# and then (a deprecation note about the test library, not about labjoint's API)
pytestmark = pytest.mark.filterwarnings(
    "ignore:Do not use the `random` module inside strategies:hypothesis.errors.HypothesisDeprecationWarning")

#: Examples per operation, and stateful scenarios: enough to reach every parameter's
#: edges without a CI minute.
EXAMPLES, SCENARIOS, STEPS = 6, 8, 6
QUIET = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                 suppress_health_check=list(HealthCheck))
#: State-changing operations anyone on this machine may call (README: e-stop from loopback).
LOOPBACK_OPEN = {("POST", "/api/v1/estop")}


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fuzz")
    data = tmp / "data"
    data.mkdir()
    cat = Catalog(data / "catalog.sqlite")
    for i, amp in enumerate((2e-6, 6e-6)):
        write_linear_run(data, cat, f"lin_{i}", amp_m=amp, n=4000)
    # reprocess jobs in the job's thread: the HTTP surface is under test, not Dask
    api = f'control_tokens = ["{CONTROL}"]\nreprocess_scheduler = "none"\n'
    svc = build(sim_config_file(tmp, api=api), data_dir=data,
                port=0, log_level="critical", env={})
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    svc.start_in_thread(sock)
    try:
        wait_for(lambda: svc.server.started, bool, timeout=10)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}"
        with http_client(url + "/api/v1", headers=AUTH) as http:
            yield url, http
            _stop_everything(http)
    finally:
        svc.stop()
        sock.close()


def _stop_everything(http: httpx.Client) -> None:
    """Cancel what the generated requests left queued or running (plans, jobs)."""
    for path, cancel in (("/plans", "/plans/{}/cancel"), ("/analyses", "/analyses/{}/cancel"),
                         ("/models/jobs", "/models/jobs/{}/cancel"),
                         ("/reprocess", "/reprocess/{}/cancel")):
        for j in http.get(path, params={"limit": 500}).json()["items"]:
            if j["status"] in ("queued", "running", "held", "waiting_torque"):
                http.post(cancel.format(j["id"]))


def _schema(url: str):
    schema = schemathesis.openapi.from_url(f"{url}/openapi.json")
    schema.config.base_url = url
    return schema


@pytest.mark.slow        # end to end, 40-120 s on a busy machine (issue 31)
def test_no_operation_answers_with_a_server_error(served):
    url, _ = served
    schema = _schema(url)
    ops = [r.ok() for r in schema.get_all_operations()]
    assert len(ops) >= 25
    for op in ops:
        @QUIET
        @given(case=op.as_strategy())
        def run(case):
            case.call_and_validate(headers=AUTH, checks=[not_a_server_error],
                                  timeout=patience.HTTP_TIMEOUT_S)   # requests' 10 s ran out under load
        run()


def test_stateful_sequences_never_get_a_server_error(served):
    url, _ = served
    machine = _schema(url).as_state_machine()
    # links inferred from the schema: a submitted job's id feeds its poll and its cancel
    steps = [n for n in dir(machine) if n.startswith("POST_api_v1_")]
    assert any("models_jobs_job_id__cancel" in n or "models_jobs_job_id_" in n for n in steps)
    assert any("POST_api_v1_analyses___202" in n and "GET_api_v1_analyses_job_id" in n for n in steps)

    class Workflow(machine):  # type: ignore[misc, valid-type]
        def get_call_kwargs(self, case):
            return {"headers": AUTH, "timeout": patience.HTTP_TIMEOUT_S}

        def validate_response(self, response, case, additional_checks=None, **kwargs):
            case.validate_response(response, checks=[not_a_server_error])

    Workflow.run(settings=settings(max_examples=SCENARIOS, stateful_step_count=STEPS,
                                   deadline=None, derandomize=True, database=None,
                                   suppress_health_check=list(HealthCheck)))


def test_every_state_changing_operation_needs_the_token(served):
    url, _ = served
    schema = _schema(url)
    checked = 0
    for op in (r.ok() for r in schema.get_all_operations()):
        if op.method.upper() == "GET" or (op.method.upper(), op.path) in LOOPBACK_OPEN:
            continue

        @settings(max_examples=2, deadline=None, derandomize=True, database=None,
                  suppress_health_check=list(HealthCheck))
        @given(case=op.as_strategy())
        def run(case):
            for headers in ({}, {"Authorization": "Bearer not-the-token"}):
                r = case.call(headers=headers, timeout=patience.HTTP_TIMEOUT_S)
                assert r.status_code in (401, 403), (op.method, op.path, r.status_code, r.text)
        run()
        checked += 1
    assert checked >= 10
