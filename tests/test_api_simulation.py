"""Simulation error over REST (issue 14): fit, diagnose and ladder jobs take
``error = "simulation"``; a fit with ``full`` returns the measured and predicted
displacement the dashboard plots; options that do not go with it are refused at submit."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.models.simulate import simulate
from labjoint.storage.catalog import Catalog
from labjoint.storage.csv_import import import_csv
from test_api_helpers import AUTH, CONTROL, live_server, wait_for
from patience import http_client

FS = 750.0
N = 1024
TRUE = {"inertia.m": 2.0, "viscous.c": 10.0, "linear_stiffness.k": 5e4}
EXPR = "inertia+viscous+linear_stiffness"


def write_record(tmp, name, seed, periods=4):
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(N, 1 / FS)
    u = np.fft.irfft(np.where((f >= 5) & (f <= 150), np.exp(2j * np.pi * rng.random(f.size)), 0), N)
    F = np.tile(u * 50.0 / np.std(u), periods)
    y = simulate(EXPR, TRUE, F, FS) + 1e-7 * rng.standard_normal(F.size)
    path = tmp / f"{name}.csv"
    np.savetxt(path, np.column_stack([np.arange(F.size) / FS, y, F]), delimiter=",",
               header=f"sample_rate_hz: {FS}\ntime_s,displacement_m,force_N", comments="# ")
    text = path.read_text().replace("# time_s", "time_s")
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def http(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sim")
    data = tmp / "data"
    data.mkdir()
    cat = Catalog(data / "catalog.sqlite")
    for i in (1, 2):
        import_csv(write_record(tmp, f"ms{i}", i), data, name=f"ms{i}", catalog=cat)
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as c:
        yield c


def test_a_simulation_fit_job_recovers_the_oscillator_and_returns_the_series(http):
    r = http.post("/models/fit", json={"runs": ["ms1"], "model": EXPR, "options": {
        "error": "simulation", "validate": ["ms2"], "full": True}})
    assert r.status_code == 202, r.text
    job = wait_for(lambda: http.get(f"/models/jobs/{r.json()['id']}").json(),
                   lambda j: j["status"] in ("complete", "failed"), timeout=120)
    assert job["status"] == "complete", job.get("error")
    res = job["result"]
    assert res["error"] == "simulation"
    for k, v in TRUE.items():
        assert res["parameters"][k]["value"] == pytest.approx(v, rel=0.01)
    (s,), (v,) = res["series"], res["validation_series"]
    assert s["run"] == "ms1" and v["run"] == "ms2"
    meas, pred = np.array(v["measured_m"]), np.array(v["predicted_m"])
    assert meas.size == 3000 and np.std(meas - pred) < 0.01 * np.std(meas)   # predicts a new record
    assert res["nrmse_validation"] < 0.01 and len(v["segment_rms_m"]) == 100


@pytest.mark.parametrize("options, field", [
    ({"error": "simulation", "multistart": 3}, "options.multistart"),
    ({"error": "simulation", "kind": "sine"}, "options.kind"),
    ({"periodic": True}, "options.periodic"),
])
def test_options_that_do_not_go_with_simulation_error_are_refused_at_submit(http, options, field):
    r = http.post("/models/fit", json={"runs": ["ms1"], "model": EXPR, "options": options})
    assert r.status_code == 422, r.text
    assert r.json()["error"]["details"]["field"] == field


def test_a_model_without_inertia_cannot_be_simulated_and_is_refused_at_submit(http):
    r = http.post("/models/fit", json={"runs": ["ms1"], "model": "viscous+linear_stiffness",
                                       "options": {"error": "simulation"}})
    assert r.status_code == 422 and "inertia" in r.json()["error"]["message"]
