"""REST: structure modes, stage-1/stage-2 updating, model FRFs and model jobs on FRF sets."""

from __future__ import annotations

import pytest

from frfdata import hidden_law, hidden_set, predictor, write_linear_structure
from labjoint.api import ApiSettings, create_app
from test_api_helpers import AUTH, CONTROL, live_server, wait_for
import patience
from patience import http_client


@pytest.fixture(scope="module")
def http(tmp_path_factory):
    data = tmp_path_factory.mktemp("structures")
    (data / "structures").mkdir()
    (data / "frf").mkdir()
    write_linear_structure(data / "structures" / "lin.toml")
    hidden_set(predictor(), hidden_law(), steps=5).save(data / "frf" / "sweep.json")
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as c:
        c.data = data
        yield c


def _done(http, path):
    return wait_for(lambda: http.get(path).json(), lambda j: j["status"] in ("complete", "failed"),
                    timeout=120)


def test_listing_and_modes(http):
    assert http.get("/structures").json() == {"structures": ["lin"], "frfsets": ["sweep"]}
    m = http.get("/structures/lin/modes", params={"count": 2}).json()
    assert len(m["frequencies_hz"]) == 2 and 35 < m["frequencies_hz"][0] < 45
    assert http.get("/structures/nothere/modes").status_code == 404
    assert http.get("/structures/..%2Fx/modes").status_code in (404, 422)


def test_update_job_and_frf_job(http):
    r = http.post("/structures/lin/update", json={"measured_hz": [38.0], "parameter": "linear_stiffness.k"})
    assert r.status_code == 202, r.text
    job = _done(http, f"/structures/jobs/{r.json()['id']}")
    assert job["status"] == "complete", job
    assert job["result"]["frequencies_hz"][0] == pytest.approx(38.0, rel=1e-3)
    r = http.post("/structures/lin/frf", json={"force_n": 1.0, "band_hz": [36, 44], "harmonics": 1,
                                               "modes": 4})
    job = _done(http, f"/structures/jobs/{r.json()['id']}")
    assert job["status"] == "complete", job
    assert job["result"]["points"] > 5
    bad = http.post("/structures/lin/frf", json={"force_n": -1, "band_hz": [36, 44]})
    assert bad.status_code == 422


def test_model_ladder_job_on_an_frf_set(http):
    r = http.post("/structures/lin/models/ladder",
                  json={"frfsets": ["sweep"], "model": "linear_stiffness", "max_steps": 1,
                        "options": {"candidates": ["viscous"], "modes": 4}})
    assert r.status_code == 202, r.text
    job = _done(http, f"/models/jobs/{r.json()['id']}")
    assert job["status"] == "complete", job
    res = job["result"]
    assert res["measurement"] == "frf" and res["steps"][-1]["added"] == "viscous"
    assert res["saved"] and (http.data / "frf").exists()
    assert http.get("/structures").json()["frfsets"] == ["sweep"]     # the result is no FRF set
    bad = http.post("/structures/lin/models/fit", json={"frfsets": ["missing"]})
    assert bad.status_code == 404
    bad = http.post("/structures/lin/models/diagnose",
                    json={"frfsets": ["sweep"], "options": {"candidates": ["gluey"]}})
    assert bad.status_code == 422 and "gluey" in bad.text


def test_the_python_client(http):
    from labjoint.client import ApiError, Client

    with Client(str(http.base_url).rstrip("/").removesuffix("/api/v1"), token=CONTROL,
                timeout=patience.HTTP_TIMEOUT_S) as c:
        assert c.structures()["structures"] == ["lin"]
        assert len(c.structure_modes("lin", 2)["frequencies_hz"]) == 2
        up = c.structure_update("lin", [38.0], parameter="linear_stiffness.k")
        assert up["frequencies_hz"][0] == pytest.approx(38.0, rel=1e-3)
        fit = c.frf_model("fit", "lin", ["sweep"], "linear_stiffness+viscous", modes=4)
        assert fit["measurement"] == "frf" and fit["parameters"]["viscous.c"]["value"] > 0
        with pytest.raises(ApiError) as e:
            c.frf_model("fit", "lin", ["nowhere"], "linear_stiffness")
        assert e.value.status == 404


def test_stage2_job(http):
    r = http.post("/structures/lin/stage2", json={"frfsets": ["sweep"], "modes": 4,
                                                  "parameters": ["linear_stiffness.k"]})
    assert r.status_code == 202, r.text
    job = _done(http, f"/structures/jobs/{r.json()['id']}")
    assert job["status"] == "complete", job
    res = job["result"]
    k = res["parameters"]["linear_stiffness.k"]
    assert 0 < k["stderr"] < 0.1 * k["value"]
    assert res["fit_steps"] == 15 and res["validation_steps"] == 0 and res["error_validation_rms"] is None
    bad = http.post("/structures/lin/stage2", json={"frfsets": ["sweep"], "parameters": ["iwan.F_S"]})
    assert bad.status_code == 422 and "iwan.F_S" in bad.text and "linear_stiffness.k" in bad.text


def test_a_structure_named_jobs_is_refused_not_shadowed(http):
    """/structures/jobs/{id} would shadow /structures/jobs/modes: the name is refused."""
    p = http.data / "structures" / "jobs.toml"
    p.write_text((http.data / "structures" / "lin.toml").read_text())
    try:
        listing = http.get("/structures").json()
        assert listing["structures"] == ["lin"]
        assert "reserved" in listing["refused"]["structures/jobs.toml"]
        r = http.post("/structures/jobs/update", json={"measured_hz": [28.5]})
        assert r.status_code == 422 and "reserved" in r.text and "jobs" in r.text
        assert http.get("/structures/jobs").status_code == 200   # the job list stays reachable
    finally:
        p.unlink()
    assert "refused" not in http.get("/structures").json()
