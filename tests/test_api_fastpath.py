"""GET /api/v1/runs/{name} answered before the router (labjoint.api.fastpath): the same
body as the run list shows, the same refusals, and never a stale answer after the
catalog changes in another connection (SQLite ``data_version``; PostgreSQL uncached)."""

from __future__ import annotations

import gzip

import httpx
import pytest

import patience
from labjoint.api import ApiSettings, create_app
from labjoint.storage import Catalog
from test_api_helpers import CONTROL, READ, READ_AUTH, live_server, write_linear_run


@pytest.fixture(scope="module", params=["sqlite", "postgresql"])
def served(tmp_path_factory, request):
    d = tmp_path_factory.mktemp("data")
    url = ("" if request.param == "sqlite" else
           request.getfixturevalue("pg_server_instance").new_database())
    cat = Catalog(url or d / "catalog.sqlite")
    for i in range(3):
        write_linear_run(d, cat, f"run_{i}", vpp=2.0 + i, n=2000)
    app = create_app(ApiSettings(data_dir=d, control_tokens=[CONTROL], read_tokens=[READ],
                                 read_requires_token=True, catalog_url=url))
    with live_server(app) as base, httpx.Client(base_url=base + "/api/v1",
                                                timeout=patience.HTTP_TIMEOUT_S) as http:
        yield http, cat


def _listed(http: httpx.Client, name: str) -> dict:
    """The run as the (routed) run list shows it, without the list's result field."""
    item, = http.get("/runs", params={"search": name}, headers=READ_AUTH).json()["items"]
    item.pop("result")
    return item


def test_summary_is_the_run_lists_entry(served):
    http, _ = served
    for name in ("run_0", "run_2"):
        r = http.get(f"/runs/{name}", headers=READ_AUTH)
        assert r.status_code == 200 and r.headers["content-type"] == "application/json"
        assert r.json() == _listed(http, name)
        assert r.json()["excitation_vpp"] == 2.0 + int(name[-1])


def test_refusals_are_the_routes(served):
    http, _ = served
    for headers in ({}, {"Authorization": "Bearer not-a-token"},
                    {"Authorization": f"Basic {READ}"}):
        r = http.get("/runs/run_1", headers=headers)
        assert r.status_code == 401 and r.json()["error"]["code"] == "unauthorized"
    r = http.get("/runs/nope", headers=READ_AUTH)
    assert r.status_code == 404 and r.json()["error"]["code"] == "not_found"
    assert http.get("/runs/.hidden", headers=READ_AUTH).status_code == 422
    assert http.get("/runs/run_1/channels", headers=READ_AUTH).status_code == 200


def test_a_change_in_another_connection_is_seen_at_once(served):
    http, cat = served
    other = Catalog(cat.sql.url or cat.sql.path)        # another connection, as another process
    before = http.get("/runs/run_1", headers=READ_AUTH).json()
    rec = other.get("run_1")
    rec.excitation_vpp, rec.status = 7.25, "aborted"
    other.put(rec)
    after = http.get("/runs/run_1", headers=READ_AUTH).json()
    assert (before["excitation_vpp"], after["excitation_vpp"]) == (3.0, 7.25)
    assert after["status"] == "aborted" and after == _listed(http, "run_1")
    assert other.remove("run_1")
    assert http.get("/runs/run_1", headers=READ_AUTH).status_code == 404


def test_gzip_still_applies(served):
    """The fast path sits inside the gzip middleware: a client that accepts gzip gets the
    same summary compressed (a summary is over the 500-byte threshold)."""
    http, _ = served
    plain = http.get("/runs/run_0", headers=READ_AUTH)
    with http.stream("GET", "/runs/run_0",
                     headers={**READ_AUTH, "Accept-Encoding": "gzip"}) as r:
        raw = b"".join(r.iter_raw())
        assert r.headers["content-encoding"] == "gzip"
    assert len(plain.content) > 500 and gzip.decompress(raw) == plain.content
