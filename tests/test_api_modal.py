"""The modal kind on the REST model routes and in the client (issue 29 item 5): the modes
uploaded or stored, the joint between two points, the shaker at a drive point, a fit
stored and predicted on the level it never saw. The records come from the independent
generator of tests/test_modal_pair_shaker.py (a 3-mass chain with a cubic joint and a
shaker, integrated by scipy's solve_ivp); bad options are 422 naming the field, with no
job queued."""

from __future__ import annotations

import json

import numpy as np
import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.client import ApiError, Client
from labjoint.storage import Catalog
from test_api_helpers import CONTROL, READ, live_server
from test_modal_pair_shaker import _basis_and_truth, _given, _record

JOB = 900.0                                  # generous: the machine is shared


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    d = tmp_path_factory.mktemp("modal")
    for i, (scale, name) in enumerate(((0.5, "low"), (1.0, "high"))):
        rec = _record(scale, name, seed=i)
        from labjoint.hardware.interfaces import ChannelSpec
        from labjoint.storage.csv_import import store_channels
        spec = lambda n, q, u: ChannelSpec(n, "imported", q, u, 1.0, range_v=np.inf, coupling="DC")  # noqa: E731
        store_channels(d / f"{name}.h5", rec.time, rec.sample_rate_hz,
                       [(spec(c.name, c.quantity, c.units), c.samples) for c in rec.channels.values()],
                       {"drive_channels": ["v"], "response_channels": ["s1", "s2", "s3"]}, d, name=name)
    _, modes, _ = _basis_and_truth()
    upload = {"levels": [{"level": 1.0, "modes": [{**m, "reference_sensor": "s2"} for m in modes]}]}
    (d / "frf").mkdir()
    (d / "frf" / "chain_modes.json").write_text(json.dumps(upload))
    Catalog(d / "catalog.sqlite").rebuild(d)
    app = create_app(ApiSettings(data_dir=d, control_tokens=[CONTROL], read_tokens=[READ]))
    with live_server(app) as url, Client(url, CONTROL) as c:
        yield c, upload, d


def _opts(upload, **kw):
    return {"modal": upload, "between": ["s2", "s3"], "shaker": _given(), "drive_point": "s1", **kw}


@pytest.mark.parametrize("op, options, field", [
    ("fit", {"between": ["s2", "s3"]}, "options.between"),
    ("fit", {"modal": "nosuch"}, "options.modal"),
    ("fit", {"modal": {"levels": []}}, "options.modal"),
    ("diagnose", "stored+between=s2,s9", "options.between"),
    ("fit", "upload+between=s2,s9", "options.between"),
    ("fit", "upload+armature", "options.shaker.armature_mass_kg"),
    ("fit", "upload+bl,r", "options.shaker.force_factor_n_per_a"),
    ("fit", "upload+drive_point=s9", "options.drive_point"),
    ("fit", "upload+bounds", "options.bounds.cubic_stiffness.k3"),
    ("fit", "upload+unknown shaker field", "options.shaker.bogus"),
    ("fit", {"modal": "chain_modes", "drive_point": "s1"}, "options.drive_point"),
    ("diagnose", "upload+save_as", "options.save_as"),
    ("fit", "upload+simulation", "options.error"),
    ("fit", {"joint_shape": True}, "options.joint_shape"),
    ("fit", "upload+joint_shape without between", "options.joint_shape"),
])
def test_bad_modal_options_are_422_naming_the_field(served, op, options, field):
    c, upload, _ = served
    if isinstance(options, str):
        base = _opts("chain_modes" if options.startswith("stored") else upload)
        extra = options.split("+", 1)[1]
        if extra.startswith("between="):
            base["between"] = extra.split("=")[1].split(",")
        elif extra == "armature":
            base["shaker"] = _given("armature_mass_kg")
        elif extra == "bl,r":
            base["shaker"] = _given("force_factor_n_per_a", "coil_resistance_ohm")
        elif extra.startswith("drive_point="):
            base["drive_point"] = "s9"
        elif extra == "bounds":
            base["bounds"] = {"cubic_stiffness.k3": [2.0, 1.0]}
        elif extra == "unknown shaker field":
            base["shaker"] = {**_given(), "bogus": 1.0}
        elif extra == "save_as":
            base["save_as"] = "x"
        elif extra == "simulation":
            base["error"] = "simulation"
        elif extra == "joint_shape without between":
            base = {"modal": upload, "joint_shape": True}
        options = base
    before = len(c.request("GET", "/models/jobs")["items"])
    with pytest.raises(ApiError) as e:
        c.request("POST", f"/models/{op}", json={"runs": ["high"], "model": "cubic_stiffness",
                                                 "options": options})
    assert e.value.status == 422, e.value
    assert e.value.details["field"] == field, e.value.details
    assert len(c.request("GET", "/models/jobs")["items"]) == before


def test_modal_fit_stored_then_predicted_over_rest(served):
    """Fit through the client (uploaded modes, joint between s2 and s3, shaker at s1, its
    coil resistance the free parameter), stored with save_as, predicted on the level it
    never saw: the parameters are the generator's and the prediction is at the noise."""
    c, upload, d = served
    _, _, truth = _basis_and_truth()
    res = c.modal_model("fit", ["high"], "cubic_stiffness", upload, between=("s2", "s3"),
                        shaker=_given("coil_resistance_ohm"), drive_point="s1",
                        modal_mass=truth["mode1.mass_kg"], bounds={"shaker.highpass_hz": (0.0, 0.0)},
                        save_as="chain", timeout=JOB)
    assert res["measurement"] == "modal" and res["saved"] == "models/chain.json"
    assert res["nrmse"] < 2e-3
    p = res["parameters"]
    assert p["shaker.coil_resistance_ohm"]["value"] == pytest.approx(_given()["coil_resistance_ohm"], rel=1e-2)
    for k in ("cubic_stiffness.k3", "modal.mass2", "modal.mass3"):
        assert p[k]["value"] == pytest.approx(truth[k], rel=1e-2), k
    assert json.loads((d / "models" / "chain.json").read_text())["between"] == ["s2", "s3"]
    pred = c.predict("chain", ["low"], timeout=JOB)
    (run,) = pred["runs"]
    assert run["record"] == "low" and run["nrmse"] < 2e-3 and run["force_rms_n"] > 0
    assert str(d) not in json.dumps(pred)
    with pytest.raises(ApiError) as e:
        c.predict("nosuch", ["low"])
    assert e.value.status == 422 and e.value.details["field"] == "model_file"


def test_a_stored_frf_set_gives_its_modes_in_the_job(tmp_path, capsys):
    """``options.modal`` naming a stored FRF set: resolved at submit to the set's file (the
    modes found when the job runs), then its modes as `labjoint modes` finds them, against
    the 2-DOF chain's closed form (tests/spectra_runs.py)."""
    from labjoint.api.modal import check_modal, modes_of
    from labjoint.cli.main import main
    from spectra_runs import closed_modes, random_force

    runs = [random_force(tmp_path / f"f{i}.h5", lv, seed=i) for i, lv in ((1, 0.5), (2, 1.0))]
    (tmp_path / "frf").mkdir()
    assert main(["frf", *map(str, runs), "--out", str(tmp_path / "frf" / "chain.json"), "--json"]) == 0
    capsys.readouterr()
    out = check_modal({"modal": "chain", "modal_band": [5.0, 120.0], "between": ["acc1", "acc2"]},
                      "fit", tmp_path)
    assert out["modal"] == (tmp_path / "frf" / "chain.json").resolve()
    basis = modes_of(out["modal"], out["modal_band"])
    got = [(m.frequency_hz, m.damping_ratio) for m in basis.modes]
    for (fg, zg), (fw, zw) in zip(got, closed_modes(False), strict=True):
        assert fg == pytest.approx(fw, rel=2e-3) and zg == pytest.approx(zw, rel=0.15)
    assert set(basis.modes[0].shape) == {"acc1", "acc2"}
