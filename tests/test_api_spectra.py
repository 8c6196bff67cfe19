"""REST /spectra and the client: FRFs, modes and distortion of catalogued run files written
by an independent generator (tests/spectra_runs.py: a 2-DOF chain under a random force and
under a voltage through a shaker; closed-form modes; a sine through a known polynomial).
The answers are the CLI's JSON; bad input is a 4xx naming the run or the channel."""

from __future__ import annotations

import json

import httpx
import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.cli.main import main
from labjoint.client import ApiError, Client
from labjoint.signal.frfset import FrfSet
from labjoint.storage import Catalog
from spectra_runs import (closed_modes, odd_multisine_cubic, random_force, random_voltage, sine_ratios,
                          sine_voltage)
from test_api_helpers import AUTH, CONTROL, READ, live_server

JOB = 120.0                                  # generous: the machine is shared


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    d = tmp_path_factory.mktemp("spectra")
    random_force(d / "force_lo.h5", 0.5, seed=1)
    random_force(d / "force_hi.h5", 1.0, seed=2)
    random_voltage(d / "volt.h5", 0.3, seed=3)
    random_force(d / "burst.h5", 0.5, seed=4, rest=0.5)
    sine_voltage(d / "sine.h5")
    odd_multisine_cubic(d / "ms.h5")
    Catalog(d / "catalog.sqlite").rebuild(d)
    app = create_app(ApiSettings(data_dir=d, control_tokens=[CONTROL], read_tokens=[READ]))
    with live_server(app) as url:
        yield url, d


def _job(http: httpx.Client, path: str, body: dict) -> dict:
    r = http.post(f"/api/v1/spectra/{path}", json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    with Client(str(http.base_url).rstrip("/"), READ) as c:
        return c._wait(lambda: c.request("GET", f"/spectra/jobs/{r.json()['id']}"),
                       ("complete", "failed", "cancelled"), JOB, 0.2)


def test_frf_and_modes_of_two_levels_against_the_closed_form(served, tmp_path, capsys):
    url, d = served
    with httpx.Client(base_url=url, timeout=JOB) as http:
        job = _job(http, "frf", {"runs": ["force_lo", "force_hi"], "name": "chain"})
        assert job["status"] == "complete", job
        res = job["result"]
        assert res["path"] == "frf/chain.json" and res["name"] == "chain"
        assert [lv["level"] for lv in res["levels"]] == [0.5, 1.0]
        assert {lv["units"] for lv in res["levels"]} == {"m/s^2/N"}
        assert str(d) not in json.dumps(res)
        # the same JSON as `labjoint frf --json` on the same files
        assert main(["frf", str(d / "force_lo.h5"), str(d / "force_hi.h5"), "--out",
                     str(tmp_path / "cli.json"), "--json"]) == 0
        cli = json.loads(capsys.readouterr().out)
        assert res["levels"] == cli["levels"]
        stored = http.get("/api/v1/spectra/frf/chain", headers={"Authorization": f"Bearer {READ}"})
        assert stored.status_code == 200
        s = FrfSet.from_dict(stored.json())
        assert s.units == "m/s^2/N" and s.sensors == ("acc1", "acc2")
        assert "chain" in http.get("/api/v1/spectra/frf").json()["frfsets"]

        job = _job(http, "modes", {"frfsets": ["chain"], "band": [5.0, 120.0]})
        assert job["status"] == "complete", job
        levels = job["result"]["levels"]
        assert [lv["level"] for lv in levels] == [0.5, 1.0]
        want = closed_modes(False)
        for lv in levels:
            got = [(m["frequency_hz"], m["damping_ratio"]) for m in lv["modes"]]
            assert len(got) == 2, got
            for (fg, zg), (fw, zw) in zip(got, want):
                assert fg == pytest.approx(fw, rel=2e-3)
                assert zg == pytest.approx(zw, rel=0.15)
        assert main(["modes", str(d / "frf" / "chain.json"), "--band", "5:120", "--json"]) == 0
        cli = json.loads(capsys.readouterr().out)["levels"]
        assert [[m["frequency_hz"] for m in lv["modes"]] for lv in levels] == \
            [[m["frequency_hz"] for m in lv["modes"]] for lv in cli]


def test_client_voltage_drive_and_distortion(served):
    url, d = served
    with Client(url, CONTROL) as c:
        got = c.frf(["volt"], "volt", overwrite=True)
        (lv,) = got["levels"]
        assert lv["units"] == "m/s/V" and lv["level_units"] == "V" and lv["drive"] == "amp"
        modes = c.modes(runs=["volt"], band=(5.0, 120.0))["levels"][0]
        assert modes["units"] == "m/s/V"
        want = closed_modes(True)
        assert [m["frequency_hz"] for m in modes["modes"]] == pytest.approx([w[0] for w in want],
                                                                            rel=2e-3)
        assert c.frf_set("volt")["format"] == "labjoint.frfset/1"
        r = c.distortion(["sine"])["runs"][0]
        assert r["excitation"] == "sine" and r["frequency_hz"] == pytest.approx(7.0, rel=1e-4)
        assert r["path"] == "sine.h5"
        amp, acc = r["channels"]["amp"], r["channels"]["acc"]
        assert amp["units"] == "V" and acc["units"] == "m/s^2"
        want = sine_ratios()
        for h in acc["harmonics"][:2]:
            assert h["ratio"] == pytest.approx(want[h["order"]], abs=3 * h["stderr"] + 1e-4)
        m = c.distortion(["ms"])["runs"][0]              # a cubic term: odd lines, no even
        assert m["excitation"] == "multisine" and m["summary"].startswith("nonlinear, odd,"), m["summary"]
        assert m["channels"]["acc"]["units"] == "m/s^2"


def test_a_burst_run_by_either_burst_estimator(served):
    """burst: "block" (the default: burst + free decay as one unwindowed block) and
    "driven" (the driven part through the local rational method), both the closed-form
    modes of the chain; the method text says which."""
    url, d = served
    with Client(url, CONTROL) as c:
        for mode, text in ((None, "1 burst block(s)"), ("block", "1 burst block(s)"),
                           ("driven", "driven part of 1 burst(s)")):
            got = c.frf(["burst"], "burst", overwrite=True, **({"burst": mode} if mode else {}))
            assert text in got["levels"][0]["method"], (mode, got["levels"][0]["method"])
            modes = c.modes(frfsets=["burst"], band=(5.0, 120.0))["levels"][0]["modes"]
            want = closed_modes(False)
            assert [m["frequency_hz"] for m in modes] == pytest.approx([w[0] for w in want], rel=2e-3)


def test_bad_input_is_4xx_naming_the_run_or_channel(served):
    url, d = served
    with Client(url, CONTROL) as c:
        cases = [
            (dict(runs=["force_lo"], name="x", drive="nothere"), 422, ["force_lo", "nothere"]),
            (dict(runs=["force_lo"], name="x", responses=["force"]), 422, ["force_lo", "force"]),
            (dict(runs=["nosuchrun"], name="x"), 404, ["nosuchrun"]),
            (dict(runs=["force_lo"], name="x", window="nowindow"), 422, ["nowindow"]),
            (dict(runs=["force_lo"], name="x", band=(50.0, 10.0)), 422, ["band"]),
            (dict(runs=["force_lo"], name="x", nperseg=1 << 24), 422,
             ["force_lo", "nperseg", "16 to 65536", "16777216"]),
            (dict(runs=["force_lo"], name="x", burst="lrm"), 422, ["burst", "block", "driven"]),
        ]
        for kw, status, words in cases:
            with pytest.raises(ApiError) as e:
                c.frf(**kw)
            assert e.value.status == status, (kw, e.value)
            for w in words:
                assert w in e.value.message, (kw, e.value.message)
            assert str(d) not in e.value.message
        with pytest.raises(ApiError) as e:       # a stored set is not replaced unasked
            c.frf(["force_lo"], "chain")
        assert e.value.status == 409
        with pytest.raises(ApiError) as e:
            c.modes(frfsets=["nosuchset"])
        assert e.value.status == 404 and "nosuchset" in e.value.message
        with pytest.raises(ApiError) as e:
            c.modes(runs=["force_lo"], frfsets=["chain"])
        assert e.value.status == 422
        with pytest.raises(ApiError) as e:
            c.distortion(["sine"], drive="acc")
        assert e.value.status == 422 and "acc" in e.value.message and "sine" in e.value.message
        # what only the samples tell fails the job with the message, not a 5xx
        job = c.request("POST", "/spectra/distortion", json={"runs": ["force_lo"]})
        done = c._wait(lambda: c.request("GET", f"/spectra/jobs/{job['id']}"),
                       ("complete", "failed", "cancelled"), JOB, 0.2)
        assert done["status"] == "failed" and done["error"]["code"] == "invalid_input"
        assert "force_lo" in done["error"]["message"] and str(d) not in done["error"]["message"]
    assert not (d / "frf" / "x.json").exists()
