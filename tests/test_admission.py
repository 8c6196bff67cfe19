"""Plans are checked against the rig's limits when submitted, not when they run
(issue 17 item 1): amplitude, frequency range, Nyquist, record length; refused over REST
with 422 naming the limit, and by `labjoint submit` with exit code 2."""

import pytest

from labjoint.acquisition.admission import check_plan
from labjoint.config import load_config
from labjoint.daemon import JobQueue
from labjoint.errors import InputError
from patience import http_client

CONFIG = load_config()        # the simulated seed 002 rig: 20 Vpp, 1 Hz-5 kHz, 600 s records


@pytest.mark.parametrize("plan, match", [
    ({"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 500}, "500 Vpp exceeds max_vpp = 20"),
    ({"plan": "dwell", "frequency_hz": 1e9, "amplitude_vpp": 2}, "exceeds max_frequency_hz"),
    ({"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 2, "n_cycles": 10**9},
     "would last 2.5e\\+06 s, above the rig's max_record_s = 600 s"),
    ({"plan": "amplitude_sweep", "amplitudes_vpp": [2, 10, 25]}, "step 9 \\(Ramp\\): amplitude 25 Vpp"),
    ({"plan": "step_sine", "frequencies_hz": [100, 200, 40000], "force_amplitude_n": 5},
     "exceeds max_frequency_hz|Nyquist"),
])
def test_a_plan_breaking_a_rig_limit_is_refused_naming_the_step_and_the_limit(plan, match):
    with pytest.raises(InputError, match=match):
        check_plan(plan, CONFIG)


def test_nyquist_of_the_configured_daq_is_a_limit_of_its_own():
    cfg = load_config(overrides={"daq": {"sample_rate_hz": 2000.0}})
    with pytest.raises(InputError, match="Nyquist frequency 1000 Hz") as err:
        check_plan({"plan": "dwell", "frequency_hz": 1200, "amplitude_vpp": 2}, cfg)
    assert err.value.field == "frequency_hz"
    check_plan({"plan": "dwell", "frequency_hz": 900, "amplitude_vpp": 2}, cfg)


def test_plans_within_the_limits_pass_including_closed_loop_ones():
    for plan in ({"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 20},
                 {"plan": "amplitude_sweep"}, {"plan": "torque_series"}, {"plan": "sensor_calibration"},
                 {"plan": "step_sine", "frequencies_hz": [380, 400, 420], "force_amplitude_n": 20}):
        check_plan(plan, CONFIG)


def test_the_queue_refuses_before_storing(tmp_path):
    q = JobQueue(tmp_path / "q.sqlite", admit=lambda p: check_plan(p, CONFIG))
    with pytest.raises(InputError, match="max_vpp"):
        q.submit({"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 500})
    assert q.list() == []
    q.submit({"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 5})
    assert len(q.list()) == 1


def test_rest_refuses_an_out_of_limits_plan_with_422_and_the_service_wires_the_check(tmp_path):
    
    from labjoint.api import ApiSettings, create_app
    from labjoint.api.server import build
    from test_api_helpers import AUTH, CONTROL, live_server, sim_config_file

    queue = JobQueue(tmp_path / "queue.sqlite", admit=lambda p: check_plan(p, CONFIG))
    app = create_app(ApiSettings(data_dir=tmp_path, control_tokens=[CONTROL]), queue=queue)
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as http:
        r = http.post("/plans", json={"plan": "dwell", "parameters": {"frequency_hz": 1e9,
                                                                       "amplitude_vpp": 500}})
        assert r.status_code == 422, r.text
        err = r.json()["error"]
        assert "max_vpp" in err["message"] and err["details"]["field"] == "amplitude_vpp"
        r = http.post("/plans", json={"plan": "dwell", "parameters": {"frequency_hz": 400,
                                                                       "amplitude_vpp": 2}})
        assert r.status_code == 202, r.text
    svc = build(sim_config_file(tmp_path), daemon=False, data_dir=tmp_path / "svc", port=0, env={})
    with pytest.raises(InputError, match="max_vpp"):
        svc.queue.submit({"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 500})


def test_the_openapi_schema_has_one_request_schema_per_plan_type(tmp_path):
    from labjoint.acquisition.plans import PLANS
    from labjoint.api import ApiSettings, create_app

    schema = create_app(ApiSettings(data_dir=tmp_path)).openapi()
    comps = schema["components"]["schemas"]
    for name in PLANS:
        title = "".join(w.title() for w in name.split("_"))
        assert f"Submit{title}" in comps and f"{title}Parameters" in comps, name
    dwell = comps["DwellParameters"]
    assert dwell["required"] == ["frequency_hz", "amplitude_vpp"]
    assert dwell["properties"]["frequency_hz"]["exclusiveMinimum"] == 0
    assert dwell["additionalProperties"] is False
    body = schema["paths"]["/api/v1/plans"]["post"]["requestBody"]["content"]["application/json"]
    assert body["schema"]["discriminator"]["propertyName"] == "plan"


def test_a_phase_resonance_plan_is_admitted_on_the_structural_rig_and_its_limits_checked():
    """The dry run's ideal rig answers on every configured channel with the response at the
    loop's target phase (it locks at once), so the plan reaches its records and ringdown;
    a level above the generator's limit is refused naming the step."""
    cfg = load_config("configs/rig-structure-sim.toml")
    plan = {"plan": "phase_resonance", "levels_vpp": [0.5, 1.5, 5.0], "f_start_hz": 28.0,
            "band_hz": [20.0, 35.0], "response_channel": "free_end", "n_cycles": 60, "ringdown_s": 8.0}
    check_plan(plan, cfg)
    with pytest.raises(InputError, match=r"step \d+ \(Ramp\): amplitude 500 Vpp"):
        check_plan({**plan, "levels_vpp": [0.5, 500.0]}, cfg)
    with pytest.raises(InputError, match="'nowhere'"):
        check_plan({**plan, "response_channel": "nowhere"}, cfg)
