"""Emergency stop semantics (issue 17 item 2): queued plans are held and never start by
themselves after the stop is cleared; each is resumed or cancelled. The stop itself needs
no token from the machine (loopback), a control token from anywhere else; its reason is
stored as given and logged escaped."""

from __future__ import annotations

import asyncio
import logging

import httpx
import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.daemon.queue import JobQueue, JobStateError
from test_api_helpers import AUTH, CONTROL

PLAN = {"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0}


def test_a_cleared_stop_starts_nothing_until_each_held_plan_is_resumed(tmp_path):
    q = JobQueue(tmp_path / "queue.sqlite")
    a, b = q.submit(PLAN), q.submit(PLAN)
    assert sorted(q.request_estop("shaker rattles")) == sorted([a, b])
    c = q.submit(PLAN)                                   # queued while latched: held too
    assert {q.get(j).status for j in (a, b, c)} == {"held"}
    with pytest.raises(JobStateError, match="still latched"):
        q.resume(a)
    q.clear_estop()
    assert q.claim_next("w") is None                     # nothing starts by itself
    assert q.resume(a).status == "queued"
    assert q.claim_next("w").id == a
    assert q.cancel(b).status == "cancelled"
    assert q.get(c).status == "held" and q.counts()["held"] == 1
    with pytest.raises(JobStateError, match="not held"):
        q.resume(b)


def test_the_reason_is_stored_as_given_and_logged_escaped(tmp_path, caplog):
    q = JobQueue(tmp_path / "queue.sqlite")
    reason = "smoke\n[ok] forged log line\x1b[2J"
    with caplog.at_level(logging.WARNING):
        q.request_estop(reason)
    assert q.estop_requested() == reason
    logged = "\n".join(r.getMessage() for r in caplog.records)
    assert "\\n[ok] forged log line\\x1b[2J" in logged and "\n[ok]" not in logged


async def _post(app, client, headers=None):
    transport = httpx.ASGITransport(app=app, client=client)
    async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1:8000") as http:
        return await http.post("/api/v1/estop", headers=headers or {},
                               json={"reason": "from the test"})


def test_the_stop_needs_no_token_from_the_machine_itself_but_does_from_elsewhere(tmp_path):
    q = JobQueue(tmp_path / "queue.sqlite")
    app = create_app(ApiSettings(data_dir=tmp_path, control_tokens=[CONTROL]), queue=q)
    far = asyncio.run(_post(app, ("192.0.2.7", 40000)))
    assert far.status_code == 401 and q.estop_requested() is None
    near = asyncio.run(_post(app, ("127.0.0.1", 40000)))
    assert near.status_code == 200 and q.estop_requested() == "from the test"
    q.clear_estop()
    assert asyncio.run(_post(app, ("192.0.2.7", 40000), AUTH)).status_code == 200
    bad = asyncio.run(_post(app, ("127.0.0.1", 40000), {"Authorization": "Bearer nope"}))
    assert bad.status_code == 401                        # a token sent is still checked
