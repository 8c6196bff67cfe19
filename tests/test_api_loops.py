"""GET /runs/{name}/loops and /runs/{name}/ladders through a real uvicorn, on runs of the
simulated rig started from rest (so each begins with a transient the steady-state
detection must drop): the loops are the steady cycles `labjoint analyze` averages, closed
over one period, with its energy loss (seed 002 Eq. 1); ladders saved by a ladder job
come back as saved."""

from __future__ import annotations

import json

import numpy as np
import pytest

from labjoint.documents import RunStop
from labjoint.api import ApiSettings, create_app
from labjoint.identify.loop import loop_area
from labjoint.storage import Catalog, write_processed
from test_api_helpers import (AUTH, CONTROL, live_server, wait_for, write_linear_run,
                              write_sim_run)
from patience import http_client

SIM = {"sim_08": 8.0, "sim_04": 4.0, "sim_14": 14.0}     # Vpp at 400 Hz, 5 N m


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    d = tmp_path_factory.mktemp("loops")
    cat = Catalog(d / "catalog.sqlite")
    paths = {n: write_sim_run(d, cat, n, vpp=v, seconds=0.25 if n == "sim_08" else 0.15)
             for n, v in SIM.items()}
    write_linear_run(d, cat, "short", n=300)          # 1.5 cycles at 100 Hz
    app = create_app(ApiSettings(data_dir=d, control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as http:
        yield http, d, cat, paths


def _cli_analyze(path, capsys) -> dict:
    from labjoint.cli.main import main
    capsys.readouterr()
    assert main(["analyze", str(path), "--json"]) == 0
    return json.loads(capsys.readouterr().out)["runs"][0]


def test_loops_are_the_steady_cycles_labjoint_analyze_averages(served, capsys):
    http, _, _, paths = served
    body = http.get("/runs/sim_08/loops", params={"max_cycles": 200,
                                                  "points_per_cycle": 256}).json()
    cli = _cli_analyze(paths["sim_08"], capsys)
    cyc = body["cycles"]
    assert body["reason"] is None and body["complete"] is True
    assert len(cyc) == body["n_steady"] == cli["cycles"] < body["n_cycles"]
    # from rest: the start transient is not steady and not returned
    assert 0 < body["steady_start"] <= min(c["index"] for c in cyc)
    assert max(c["index"] for c in cyc) < body["steady_stop"] <= body["n_cycles"]
    area = np.array([loop_area(np.array(c["displacement_m"]), np.array(c["force_n"]))
                     for c in cyc])
    energy = np.array([c["energy_loss_j"] for c in cyc])
    assert np.all(area > 0)                                  # dissipative loops
    np.testing.assert_allclose(area, energy, rtol=0.02)      # the loop drawn is the loop measured
    assert area.mean() == pytest.approx(cli["energy_loss_j"], rel=0.02)
    assert energy.mean() == pytest.approx(body["summary"]["energy_loss_j"], rel=1e-9)
    assert np.mean([c["stiffness_n_per_m"] for c in cyc]) == pytest.approx(
        cli["stiffness_n_per_m"], rel=1e-9)
    for c in cyc:
        u = np.array(c["displacement_m"])
        U = c["displacement_amplitude_m"]
        assert (u.max() - u.min()) / 2 == pytest.approx(U, rel=0.01)
        # one period from the fundamental's upward zero crossing, closing on itself
        assert abs(u[0]) < 0.03 * U and u[1] > u[0]
        step = 2 * np.pi * U / u.size
        assert abs(u[-1] - u[0]) < 2 * step


def test_max_cycles_and_points_bound_the_answer(served):
    http, _, _, _ = served
    every = http.get("/runs/sim_08/loops", params={"max_cycles": 200}).json()
    last = http.get("/runs/sim_08/loops", params={"max_cycles": 5, "points_per_cycle": 32}).json()
    assert [c["index"] for c in last["cycles"]] == [c["index"] for c in every["cycles"]][-5:]
    assert last["points_per_cycle"] == 32
    assert all(len(c["displacement_m"]) == len(c["force_n"]) == 32 for c in last["cycles"])
    # never more points than a cycle holds samples (50 kS/s at 400 Hz: 125)
    fine = http.get("/runs/sim_08/loops", params={"max_cycles": 1, "points_per_cycle": 1024}).json()
    assert len(fine["cycles"]) == 1 and fine["points_per_cycle"] == 125
    assert len(fine["cycles"][0]["displacement_m"]) == 125


@pytest.mark.parametrize("params", [{"points_per_cycle": 4}, {"points_per_cycle": 5000},
                                    {"max_cycles": 0}, {"max_cycles": 201},
                                    {"max_cycles": "many"}, {"force": "strain"}])
def test_bad_parameters_are_422(served, params):
    http, _, _, _ = served
    r = http.get("/runs/sim_08/loops", params=params)
    assert r.status_code == 422 and next(iter(params)) in r.json()["error"]["message"]


def test_unknown_or_malformed_run_is_404_or_422(served):
    http, _, _, _ = served
    for path in ("loops", "ladders"):
        r = http.get(f"/runs/nope/{path}")
        assert r.status_code == 404 and r.json()["error"]["code"] == "not_found"
        assert http.get(f"/runs/.hidden/{path}").status_code == 422


def test_a_run_without_steady_cycles_gets_an_empty_list_and_the_reason(served):
    http, _, _, _ = served
    r = http.get("/runs/short/loops")
    assert r.status_code == 200
    body = r.json()
    assert body["cycles"] == [] and body["n_steady"] == 0
    assert "cycles" in body["reason"] and "at least 3" in body["reason"]


def test_a_run_still_being_written_gives_the_cycles_so_far(served):
    http, d, cat, _ = served
    writer = write_sim_run(d, cat, "live", vpp=8.0, seconds=0.15, stop=False)
    try:
        assert http.get("/runs/live").json()["status"] == "running"
        body = http.get("/runs/live/loops", params={"max_cycles": 3}).json()
        assert body["complete"] is False and body["status"] == "running"
        assert len(body["cycles"]) == 3 and body["n_cycles"] >= 55   # 0.15 s at 400 Hz
        writer("stop", RunStop("uid-live", "complete", n_samples=7500))
        done = http.get("/runs/live/loops", params={"max_cycles": 3}).json()
        assert done["complete"] is True
        assert [c["index"] for c in done["cycles"]] == [c["index"] for c in body["cycles"]]
    finally:
        writer.close()


def test_a_ladder_job_is_saved_in_the_run_files_and_served_as_saved(served):
    http, d, _, _ = served
    r = http.post("/models/ladder", json={"runs": list(SIM), "model": "linear_stiffness",
                                          "max_steps": 1,
                                          "options": {"candidates": ["viscous", "coulomb"]}})
    assert r.status_code == 202, r.text
    job = wait_for(lambda: http.get(f"/models/jobs/{r.json()['id']}").json(),
                   lambda j: j["status"] in ("complete", "failed"), timeout=120)
    assert job["status"] == "complete", job["error"]
    lad = job["result"]
    assert len(lad["steps"]) == 2 and lad["steps"][1]["nrmse"] < lad["steps"][0]["nrmse"]
    for name in SIM:
        body = http.get(f"/runs/{name}/ladders").json()
        assert body["run"] == name and body["damaged"] == {}
        (saved,) = [x for x in body["ladders"] if x["key"] == lad["key"]]
        assert [(s["model"], s["added"]) for s in saved["steps"]] == \
            [(s["model"], s["added"]) for s in lad["steps"]]
        assert [s["nrmse"] for s in saved["steps"]] == pytest.approx(
            [s["nrmse"] for s in lad["steps"]], rel=1e-12)
        assert saved["noise_floor"] == pytest.approx(lad["noise_floor"], rel=1e-12)
        assert sorted(saved["runs"]) == sorted(SIM) and saved["saved_at"]
    assert http.get("/runs/short/ladders").json()["ladders"] == []


def test_a_damaged_ladder_group_is_reported_not_a_500(served):
    http, d, cat, _ = served
    write_linear_run(d, cat, "damaged", n=2000)
    write_processed(d / "damaged.h5", "model_ladder_0123456789ab", {"nrmse": np.zeros(1)},
                    {"ladder": "{not json"})
    r = http.get("/runs/damaged/ladders")
    assert r.status_code == 200
    body = r.json()
    assert body["ladders"] == [] and list(body["damaged"]) == ["model_ladder_0123456789ab"]


def test_diagnose_with_full_carries_measured_and_model_loops_per_run(served):
    """What the models page overlays: per run, the mean steady cycle measured and modelled;
    the measured one encloses the energy the loops endpoint reports (seed 002 Eq. 1)."""
    http, _, _, _ = served
    r = http.post("/models/diagnose", json={"runs": list(SIM), "model": "linear_stiffness",
                                            "options": {"candidates": ["viscous"], "full": True}})
    assert r.status_code == 202, r.text
    job = wait_for(lambda: http.get(f"/models/jobs/{r.json()['id']}").json(),
                   lambda j: j["status"] in ("complete", "failed"), timeout=120)
    assert job["status"] == "complete", job["error"]
    res = job["result"]
    assert set(res["loops"]) == set(SIM) == {x["run"] for x in res["runs"]}
    for name, lp in res["loops"].items():
        u, fm, fd = (np.array(lp[k]) for k in ("displacement_m", "force_measured_n",
                                               "force_model_n"))
        assert u.size == fm.size == fd.size >= 64
        steady = http.get(f"/runs/{name}/loops", params={"max_cycles": 200}).json()
        w = np.mean([c["energy_loss_j"] for c in steady["cycles"]])
        assert loop_area(u, fm) == pytest.approx(w, rel=0.05)
        # a spring alone dissipates nothing: its loop is a line
        assert abs(loop_area(u, fd)) < 0.05 * w
