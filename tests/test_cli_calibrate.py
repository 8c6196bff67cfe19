"""`labjoint calibrate`, `labjoint friction` and `analyze --friction-run` end to end on the
simulated rig: calibration runs -> stored N/V table -> later runs read with it; friction
test -> stored mu -> the stick-slip analysis uses it; bad input -> exit code 2."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.config import CONFIG_DIR
from labjoint.hardware.sim.config import NanocompositeConfig, SimConfig
from labjoint.hardware.sim.sensors import nanocomposite_true_factor
from labjoint.identify.calibration import phasors
from labjoint.storage import open_run

#: A nanocomposite sensor unlike the config's 301 N/V: 250 N/V at 400 Hz and a
#: piezoresistive shelf high enough that the factor changes with frequency (322 N/V at 100 Hz).
SENSOR = {"factor_n_per_v": 250.0, "shelf_hz": 150.0}
FS = "25000"
MU_SIM = SimConfig().contact.friction_coefficient


def _cli(args: list[str]) -> tuple[int, str, str]:
    """Run `labjoint ARGS` in-process: (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    return rc, out.getvalue(), err.getvalue()


def _json(args: list[str]) -> dict:
    """`labjoint ARGS` must succeed and print exactly one JSON object."""
    rc, out, err = _cli(args)
    assert rc == 0, err
    lines = [ln for ln in out.splitlines() if ln.strip()]
    assert len(lines) == 1, out
    return json.loads(lines[0])


def _plan(path: Path, **fields) -> str:
    lines = [f"{k} = {json.dumps(v)}" for k, v in fields.items()]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def _simulate(tmp: Path, out: Path, config: str | None = None, **plan) -> list[str]:
    """Run a plan through `labjoint simulate`; the run files it wrote."""
    args = ["simulate", "--plan", _plan(tmp / f"{plan['plan']}.toml", **plan), "--out", str(out),
            "--sample-rate", FS, "--json"]
    res = _json(args + (["--config", config] if config else []))
    assert res["status"] == "complete"
    return [str(out / f"{r['run']}.h5") for r in res["runs"]]


def _force_ratio(path: str) -> tuple[float, dict]:
    """|joint force from the joint sensor| / |joint force from the reference sensor| at the
    drive frequency: the reference carries beam 1's inertia and support, removed with the
    geometry the run's metadata records (F_joint = F_ref + (m w^2 - k_s - i w c_s) X_1)."""
    with open_run(path) as rf:
        md = rf.metadata
        f, fs = rf.frequency_hz, rf.sample_rate_hz
        nc, ref, x1 = (rf.physical(c) for c in ("shear_nc", "force_ref", "disp_1"))
    p_nc, p_ref, p_x1 = phasors(np.stack([nc, ref, x1]), fs, f)[:, 0]
    w = 2 * np.pi * f
    dyn = md["beam_mass_kg"] * w ** 2 - md["beam_support_stiffness_n_per_m"] \
        - 1j * w * md["beam_support_damping_ns_per_m"]
    return float(abs(p_nc) / abs(p_ref + dyn * p_x1)), md


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """Other sensor than configured: dwell, calibration runs, calibrate, dwell again."""
    tmp = tmp_path_factory.mktemp("cal")
    text = (CONFIG_DIR / "rig-sim.toml").read_text()
    sensor = "".join(f"{k} = {v}\n" for k, v in SENSOR.items())
    assert "[sim]\nseed = 0\n" in text
    config = tmp / "rig.toml"
    config.write_text(text.replace("[sim]\nseed = 0\n",
                                   f"[sim]\nseed = 0\n[sim.sensors.nanocomposite]\n{sensor}"))
    out = tmp / "data"
    dwell = dict(plan="dwell", frequency_hz=400.0, amplitude_vpp=10.0, n_cycles=40)
    (before,) = _simulate(tmp, out, str(config), **dwell)
    cal_files = _simulate(tmp, out, str(config), plan="sensor_calibration",
                          frequencies_hz=[100.0, 400.0], amplitude_vpp=10.0, n_cycles=60)
    cal = _json(["calibrate", *cal_files, "--data-dir", str(out), "--json"])
    (after,) = _simulate(tmp, out, str(config), **dwell)
    return {"before": before, "after": after, "cal": cal, "cal_files": cal_files, "out": out}


def test_calibrate_recovers_the_sensors_true_factor_per_frequency(calibrated):
    cal = calibrated["cal"]
    true = NanocompositeConfig(**SENSOR)
    points = {p["frequency_hz"]: p for p in cal["points"]}
    assert sorted(points) == [100.0, 400.0]
    for f, p in points.items():
        assert p["n_per_v"] == pytest.approx(float(nanocomposite_true_factor(f, true)), rel=0.02)
        assert p["channel"] == "shear_nc" and p["beam_mass_kg"] == 1.0   # from the run file
    assert points[100.0]["n_per_v"] / points[400.0]["n_per_v"] > 1.2     # the shelf is seen
    table = cal["tables"]["shear_nc"]
    assert [t["frequency_hz"] for t in table] == [100.0, 400.0]
    assert Path(cal["store"]).is_file()


def test_later_runs_use_the_calibrated_factor_at_their_frequency(calibrated):
    cal = {p["frequency_hz"]: p for p in calibrated["cal"]["points"]}
    ratio_before, md_before = _force_ratio(calibrated["before"])
    ratio_after, md_after = _force_ratio(calibrated["after"])
    # before: read with the config's 301 N/V, 20 % above the 250 N/V sensor
    used = md_before["calibration"]["shear_nc"]
    assert used["source"] == "sensitivity" and used["factor"] == 301.0
    assert ratio_before == pytest.approx(301.0 / 250.0, rel=0.03)
    assert abs(ratio_before - 1) > 0.15
    # after: the 400 Hz point (not the 100 Hz one), with the run it came from
    used = md_after["calibration"]["shear_nc"]
    assert used["frequency_hz"] == md_after["frequency_hz"] == 400.0
    assert used["factor"] == pytest.approx(cal[400.0]["n_per_v"], rel=1e-12)
    assert used["interpolation"] == "exact" and used["unit"] == "N/V"
    (point,) = used["points"]
    assert point["runs"] == [cal[400.0]["run"]] and point["uncertainty"] > 0
    assert abs(ratio_after - 1) < 0.03
    # the other channels say what they were read with
    assert md_after["calibration"]["force_ref"] == {
        "factor": 50.0, "unit": "N/V", "frequency_hz": 400.0, "source": "sensitivity",
        "interpolation": "none"}


def test_friction_identified_stored_and_used_by_the_stickslip_analysis(tmp_path):
    out = tmp_path / "data"
    (fric,) = _simulate(tmp_path, out, plan="friction_test", n_cycles=40)
    (dwell,) = _simulate(tmp_path, out, plan="dwell", frequency_hz=400.0, amplitude_vpp=20.0,
                         n_cycles=30)
    mu = _json(["friction", fric, "--data-dir", str(out), "--json"])
    assert mu["friction_coefficient"] == pytest.approx(MU_SIM, rel=0.05)
    assert mu["normal_force_n"] == pytest.approx(2.0 * 478.0)
    assert mu["run"] == Path(fric).stem and Path(mu["store"]).is_file()
    # a later stick-slip analysis takes mu from the store and says where it came from
    (row,) = _json(["analyze", dwell, "--method", "stickslip", "--data-dir", str(out),
                    "--json"])["runs"]
    assert row["friction_source"] == Path(fric).stem
    assert row["friction_coefficient"] == pytest.approx(mu["friction_coefficient"])
    assert row["stickslip_energy_loss_j"] > 0
    # --friction-run identifies it for this analysis only (nothing stored in the empty dir)
    empty = tmp_path / "empty"
    (row,) = _json(["analyze", dwell, "--method", "stickslip", "--friction-run", fric,
                    "--data-dir", str(empty), "--json"])["runs"]
    assert row["friction_source"] == Path(fric).stem
    assert row["friction_coefficient"] == pytest.approx(mu["friction_coefficient"])
    assert not (empty / "identified.json").exists()
    # a stated torque-to-normal ratio overrides the file's: twice the ratio, half the mu
    half = _json(["friction", fric, "--torque-to-normal", "956", "--data-dir", str(empty),
                  "--json"])
    assert half["normal_force_n"] == pytest.approx(2.0 * 956.0)
    assert half["friction_coefficient"] == pytest.approx(mu["friction_coefficient"] / 2, rel=1e-9)


def _fails(args: list[str]) -> str:
    """`labjoint ARGS` must fail with exit code 2, nothing on stdout; its stderr."""
    rc, out, err = _cli(args)
    assert rc == 2 and out == "", (rc, out, err)
    return err


def test_bad_input_names_the_file_and_what_is_wrong(calibrated, tmp_path):
    out = tmp_path / "store"
    before, good = calibrated["before"], calibrated["cal_files"][1]
    err = _fails(["calibrate", before, "--data-dir", str(out), "--json"])
    assert before in err and "'plan'" in err and "not a sensor_calibration run" in err
    assert not (out / "calibrations.json").exists()           # nothing usable: nothing stored
    missing = str(tmp_path / "nope.h5")
    assert missing in _fails(["friction", missing, "--data-dir", str(out)])
    assert missing in _fails(["calibrate", missing, "--data-dir", str(out)])
    err = _fails(["friction", before, "--data-dir", str(out)])
    assert before in err and "not a friction_test run" in err
    # the physics check: a micro-slip run has no sliding plateau
    err = _fails(["friction", before, "--any-plan", "--data-dir", str(out)])
    assert before in err and "no sliding plateau" in err
    assert not (out / "identified.json").exists()
    err = _fails(["calibrate", good, "--channel", "nosuch", "--data-dir", str(out)])
    assert "'--channel'" in err and "nosuch" in err


def test_calibrate_refuses_a_run_without_reference_force_channel(calibrated, tmp_path):
    from labjoint.documents import Block, RunStart, RunStop
    from labjoint.storage import RunWriter

    src = calibrated["cal_files"][1]
    with open_run(src) as rf:
        specs = [c for c in rf.channels if c.name != "force_ref"]
        volts = np.stack([rf.volts(c.name) for c in specs])
        md = {k: v for k, v in rf.metadata.items()
              if k in ("frequency_hz", "sample_rate_hz", "plan", "joint_force_channel",
                       "reference_force_channel", "displacement_channels", "beam_mass_kg")}
        fs = rf.sample_rate_hz
    with RunWriter(tmp_path) as w:
        w("start", RunStart("u1", "noref", specs, fs, md))
        w("block", Block("u1", 0, volts))
        w("stop", RunStop("u1", "complete", n_samples=volts.shape[1]))
    path = str(tmp_path / "noref.h5")
    err = _fails(["calibrate", path, "--data-dir", str(tmp_path)])
    assert path in err and "no reference force channel 'force_ref'" in err


def test_one_bad_record_is_named_and_the_good_ones_are_used(calibrated, tmp_path, capsys):
    out = tmp_path / "store"
    good = calibrated["cal_files"]
    broken = tmp_path / "truncated.h5"
    broken.write_bytes(Path(good[0]).read_bytes()[:4096])      # a cut-off copy
    wrong = calibrated["before"]                              # a dwell, not a calibration run
    rc = main(["calibrate", good[0], str(broken), wrong, good[1], "--data-dir", str(out),
               "--json"])
    cap = capsys.readouterr()
    assert rc == 1
    body = json.loads(cap.out)
    assert sorted(p["file"] for p in body["points"]) == sorted(good)
    assert [f["file"] for f in body["failed"]] == [str(broken), wrong]
    assert str(broken) in cap.err and wrong in cap.err and "not a sensor_calibration run" in cap.err
    stored = json.loads((out / "calibrations.json").read_text())
    assert len(stored["channels"]["shear_nc"]["points"]) == 2
    # only bad files: refused (exit 2), and the store is left exactly as it was
    before = (out / "calibrations.json").read_bytes()
    assert main(["calibrate", str(broken), wrong, "--data-dir", str(out)]) == 2
    err = capsys.readouterr().err
    assert str(broken) in err and wrong in err
    assert (out / "calibrations.json").read_bytes() == before
