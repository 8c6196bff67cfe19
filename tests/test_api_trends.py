"""GET /trends (issue 17 item 11) on a simulated amplitude sweep: the runs a GET /runs
filter selects, both methods with uncertainties, seed 002 Tables 2-4 and the
dissipation exponent, as the Python layer gives them; read auth; OpenAPI."""

from __future__ import annotations

import asyncio
import contextlib
import io

import httpx
import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.cli.main import main
from labjoint.identify.identified import Identified, save_identified
from labjoint.identify.trends import build_trends, trend_rows
from test_api_helpers import CONTROL, READ, READ_AUTH

MU = 0.168
VPP = [2.0, 4.0, 8.0, 12.0]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """A data directory with `labjoint simulate --sweep 2,4,8,12` (and its catalog) and a
    stored friction coefficient."""
    d = tmp_path_factory.mktemp("trends-api")
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["simulate", "--sweep", ",".join(map(str, VPP)), "--cycles", "20",
                     "--sample-rate", "25000", "--out", str(d), "--json"]) == 0
    save_identified(d, Identified("friction_coefficient", MU, 0.005, "1", "test", "given"))
    return d


def _get(app, path, params=None, headers=None, prefix="/api/v1"):
    async def go():
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport,
                                     base_url="http://127.0.0.1:8000") as http:
            return await http.get(prefix + path, params=params, headers=headers or {})
    return asyncio.run(go())


def test_trends_of_a_filter_match_the_python_layer(data):
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    r = _get(app, "/trends", {"plan": "amplitude_sweep", "vpp_min": 3, "order": "excitation_vpp"})
    assert r.status_code == 200, r.text
    body = r.json()
    files = sorted(data.glob("*.h5"))
    picked = [p for p, v in zip(files, VPP) if v >= 3]
    assert body["selection"] == {"runs": [p.stem for p in picked], "truncated": False}
    assert [x["excitation_vpp"] for x in body["runs"]] == [4.0, 8.0, 12.0]
    ref = build_trends(trend_rows(picked, MU))       # the stored mu was used
    assert body["methods"] == ["loop", "stickslip"]
    for got, want in zip(body["runs"], ref["runs"]):
        for key in ("energy_loss_j", "energy_loss_j_uncertainty", "stickslip_damping_ns_per_m",
                    "stickslip_damping_ns_per_m_uncertainty", "force_amplitude_n"):
            assert got[key] == pytest.approx(want[key], rel=1e-12), key
    assert body["fit"]["exponent"] == pytest.approx(ref["fit"]["exponent"], rel=1e-12)
    lo, hi = body["fit"]["exponent_ci95"]
    assert lo < body["fit"]["exponent"] < hi and body["fit"]["n_amplitudes"] == 3
    assert "2.5-3" in body["fit"]["reference"]
    w = [x["energy_loss_j"] for x in body["runs"]]
    assert w == sorted(w)                            # physics: more force, more loss
    assert len(body["table"]["rows"]) == 9 and body["table"]["conditions"] == ["excitation_vpp"]


def test_two_amplitudes_give_the_table_and_a_refused_exponent(data):
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    names = [p.stem for p in sorted(data.glob("*.h5"))[:2]]
    body = _get(app, "/trends", {"run": names, "friction_coefficient": 0.2}).json()
    assert [x["run"] for x in body["runs"]] == names
    assert body["runs"][0]["friction_coefficient"] == 0.2
    assert body["fit"]["exponent"] is None
    assert "2 distinct amplitudes" in body["fit"]["error"]
    assert len(body["table"]["rows"]) == 6


def test_bad_requests_are_named(data):
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    r = _get(app, "/trends", {"run": "no_such_run"})
    assert r.status_code == 404 and "no_such_run" in r.json()["error"]["message"]
    r = _get(app, "/trends", {"run": "../etc"})
    assert r.status_code == 422 and r.json()["error"]["details"]["field"] == "run"
    for mu in (-1, 1e-300):        # 1e-300 overflowed the stick-slip loads (schemathesis)
        r = _get(app, "/trends", {"friction_coefficient": mu})
        assert r.status_code == 422 and "friction_coefficient" in r.text
    assert _get(app, "/trends", {"until": "2000-01-01"}).json()["runs"] == []


def test_reads_follow_the_read_rules_and_the_schema_documents_it(data):
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL], read_tokens=[READ],
                                 read_requires_token=True))
    assert _get(app, "/trends").status_code == 401
    assert _get(app, "/trends", {"vpp_max": 2}, headers=READ_AUTH).status_code == 200
    spec = _get(app, "/openapi.json", prefix="").json()
    op = spec["paths"]["/api/v1/trends"]["get"]
    params = {p["name"] for p in op["parameters"]}
    assert {"run", "plan", "vpp_min", "vpp_max", "torque_nm", "since", "limit",
            "friction_coefficient"} <= params
    ref = op["responses"]["200"]["content"]["application/json"]["schema"]["$ref"]
    trends = spec["components"]["schemas"][ref.rsplit("/", 1)[1]]
    assert {"runs", "table", "fit", "fits"} <= set(trends["properties"])
    assert op.get("security")                        # reads need a token on this server
