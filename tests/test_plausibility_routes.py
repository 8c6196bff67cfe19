"""The plausibility limits (issue 29 item 6) on the REST model jobs and in batch reprocess,
as the CLI has them: a [plausibility] table and a displacement cap over it, checked
before the fit (a joint run of 2 cm amplitude is refused by the default 1 cm cap and
taken with the cap raised)."""

from __future__ import annotations

import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.api.routes.models import check_options as rest_options
from labjoint.batch.options import check_options as batch_options
from labjoint.batch.reprocess import SerialRunner, execute, plan_reprocess
from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.identify.plausible import Plausibility
from labjoint.storage.catalog import Catalog
from labjoint.storage.results import Results
from patience import http_client
from test_api_helpers import AUTH, CONTROL, live_server, wait_for, write_linear_run

AMP = 0.02          # m: above the default 1 cm cap


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    d = tmp_path_factory.mktemp("plaus")
    cat = Catalog(d / "catalog.sqlite")
    for i, f in enumerate((20.0, 30.0)):
        write_linear_run(d, cat, f"big_{i}", amp_m=AMP * (1 + 0.3 * i), f=f, k=1e3, c=2.0, n=8000)
    return d, cat


def test_rest_options_build_the_limits_and_refuse_by_name():
    out = rest_options("fit", {"max_displacement": 0.05, "plausibility": {"min_samples_per_period": 8}})
    assert out["plausibility"] == Plausibility(max_displacement_amplitude_m=0.05, min_samples_per_period=8.0)
    assert "max_displacement" not in out
    with pytest.raises(InputError) as e:
        rest_options("diagnose", {"plausibility": {"max_displacement": 1.0}})
    assert e.value.field == "options.plausibility.max_displacement"
    with pytest.raises(InputError) as e:
        rest_options("ladder", {"max_displacement": -1.0})
    assert e.value.field == "options.max_displacement"
    with pytest.raises(InputError, match="simulation") as e:
        rest_options("fit", {"max_displacement": 0.05, "error": "simulation"})
    assert e.value.field == "options.max_displacement"


def test_batch_options_key_the_result_by_the_limits():
    a = batch_options("fit", {"model": "linear_stiffness", "max_displacement": 0.05})
    b = batch_options("fit", {"model": "linear_stiffness", "plausibility": {"max_displacement_amplitude_m": 0.05}})
    assert a == b == {"model": "linear_stiffness", "plausibility": {"max_displacement_amplitude_m": 0.05}}
    with pytest.raises(InputError) as e:
        batch_options("diagnose", {"model": "linear_stiffness", "plausibility": {"gap": 1}})
    assert e.value.field == "plausibility.gap"


def test_reprocess_fit_refused_by_the_cap_then_taken_with_it_raised(lab):
    d, cat = lab
    res = Results(cat)
    for opts, ok in (({}, False), ({"max_displacement": 0.05}, True)):
        o = batch_options("fit", {"model": "linear_stiffness+viscous", **opts})
        rep = execute(plan_reprocess(res, cat.query(), "fit", o, group_by=None), SerialRunner(), res)
        if ok:
            assert rep["failed"] == 0 and rep["computed"] >= 1
        else:
            assert rep["failed"] >= 1
            assert "max-displacement" in str(rep["runs"][0].get("error", rep["runs"][0]))


def test_reprocess_cli_takes_max_displacement(lab, capsys):
    d, _ = lab
    assert main(["reprocess", "--data-dir", str(d), "--pipeline", "fit", "--model", "linear_stiffness",
                 "--scheduler", "none", "--max-displacement", "-1"]) == 2
    assert "--max-displacement" in capsys.readouterr().err


@pytest.mark.slow
def test_rest_fit_job_takes_the_cap(lab):
    d, _ = lab
    app = create_app(ApiSettings(data_dir=d, control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as http:
        for opts, want in (({}, "failed"), ({"max_displacement": 0.05}, "complete")):
            r = http.post("/models/fit", json={"runs": ["big_0", "big_1"], "model": "linear_stiffness+viscous",
                                               "options": opts})
            assert r.status_code == 202, r.text
            job = wait_for(lambda: http.get(f"/models/jobs/{r.json()['id']}").json(),
                           lambda j: j["status"] in ("complete", "failed"))
            assert job["status"] == want, job
            if want == "complete":
                assert job["result"]["parameters"]["linear_stiffness.k"]["value"] == pytest.approx(1e3, rel=0.02)
