"""REST and client: stored backbone files (listing, reading) and the comparison loop on
them inside a structure, alone and beside an FRF set, as model jobs; bad requests refused."""

from __future__ import annotations

import pytest

import patience
from backbonedata import measured, write
from frfdata import hidden_law, hidden_set, predictor, write_linear_structure
from labjoint.api import ApiSettings, create_app
from labjoint.client import ApiError, Client
from patience import http_client
from test_api_helpers import AUTH, CONTROL, live_server, wait_for


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    data = tmp_path_factory.mktemp("bbloop")
    for d in ("structures", "frf", "backbones"):
        (data / d).mkdir()
    write_linear_structure(data / "structures" / "lin.toml")
    pr = predictor()
    write(data / "backbones" / "pr.json", measured(pr, hidden_law(), n=7))
    write(data / "backbones" / "two.json", measured(pr, hidden_law(), n=2))
    hidden_set(pr, hidden_law(), steps=5).save(data / "frf" / "sweep.json")
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as c:
        c.data, c.url = data, url
        yield c


def _done(http, path):
    return wait_for(lambda: http.get(path).json(), lambda j: j["status"] in ("complete", "failed"),
                    timeout=300)


def test_stored_backbones_are_listed_and_read(served):
    assert served.get("/backbones").json() == {"backbones": ["pr", "two"]}
    f = served.get("/backbones/pr").json()
    assert f["format"] == "labjoint.backbone/1" and f["mode"] == 1
    pts = f["backbones"][0]["points"]
    assert len(pts) == 7 and {p["method"] for p in pts} == {"phase_resonance"}
    assert all(p["frequency_sd_hz"] > 0 and p["damping_sd"] > 0 for p in pts)
    assert served.get("/backbones/nothere").status_code == 404


def test_model_jobs_on_backbones_and_their_refusals(served):
    r = served.post("/structures/lin/models/fit",
                    json={"backbones": ["pr"], "model": "linear_stiffness", "options": {"modes": 4}})
    assert r.status_code == 202, r.text
    job = _done(served, f"/models/jobs/{r.json()['id']}")
    assert job["status"] == "complete", job
    res = job["result"]
    assert res["measurement"] == "backbone" and res["kind"] == "backbone"
    assert res["parameters"]["linear_stiffness.k"]["value"] > 0
    # a linear joint has no amplitude dependence: far above the points' uncertainties
    assert res["nrmse"] > 10 * res["noise_floor"]
    assert served.post("/structures/lin/models/fit", json={"model": "linear_stiffness"}).status_code == 422
    assert served.post("/structures/lin/models/fit", json={"backbones": ["nothere"]}).status_code == 404
    r = served.post("/structures/lin/models/fit", json={"backbones": ["two"], "options": {"modes": 4}})
    job = _done(served, f"/models/jobs/{r.json()['id']}")       # too few points: the job says why
    assert job["status"] == "failed" and "too few" in job["error"]["message"]


def test_linear_damping_measured_from_the_stored_backbone(served):
    from labjoint.compare.backbone_damping import linear_range
    from labjoint.errors import InputError
    from labjoint.signal.backbone import load_backbones

    bad = served.post("/structures/lin/models/fit", json={"backbones": ["pr"], "options": {
        "modes": 4, "linear_damping": "guessed"}})
    assert bad.status_code == 422
    try:
        expect = linear_range(load_backbones(served.data / "backbones" / "pr.json")[0])
    except InputError:
        expect = None
    r = served.post("/structures/lin/models/fit", json={"backbones": ["pr"], "model": "linear_stiffness",
                                                          "options": {"modes": 4, "linear_damping": "measured"}})
    assert r.status_code == 202, r.text
    job = _done(served, f"/models/jobs/{r.json()['id']}")
    if expect is None:
        assert job["status"] == "failed" and "linear range" in job["error"]["message"]
    else:
        assert job["status"] == "complete", job
        assert f"{expect['zeta']:.5g}" in job["result"]["linear_damping"]


@pytest.mark.slow
def test_the_client_diagnoses_backbones_beside_an_frf_set(served):
    with Client(served.url, token=CONTROL, timeout=patience.HTTP_TIMEOUT_S) as c:
        assert c.stored_backbones() == ["pr", "two"]
        assert c.stored_backbone("pr")["mode"] == 1
        res = c.backbone_model("diagnose", "lin", ["pr"], "linear_stiffness", frfsets=["sweep"],
                               modes=4, candidates=["viscous", "iwan"])
        assert res["kind"] == "frf+backbone" and res["measurement"] == "frf+backbone"
        kinds = {f["kind"] for f in res["failures"]}
        assert kinds == {"frf", "backbone"}
        assert any(f["text"].startswith("damping too low above") for f in res["failures"])
        with pytest.raises(ApiError) as e:
            c.backbone_model("fit", "lin", ["nothere"], "linear_stiffness")
        assert e.value.status == 404
