"""Wiring of the identification inputs: rig geometry from the config into every run's
metadata and from there into the pipelines; stored sensor calibrations applied by the
daemon before each job, with the factor used recorded per channel."""

from __future__ import annotations

import json

import numpy as np
import pytest

from labjoint.acquisition.calibrations import channel_calibrations
from labjoint.acquisition.plans import dwell
from labjoint.acquisition.rig import open_rig
from labjoint.config import CONFIG_DIR, RigSection, load_config
from labjoint.errors import ConfigError, InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.hardware.sim.config import SimConfig
from labjoint.hardware.sim.sensors import nanocomposite_true_factor
from labjoint.identify.calibration import CalibrationStore, calibrate_run, calibrate_runs, phasors
from labjoint.identify.friction import run_normal_force
from labjoint.identify.stickslip import StickSlipIdentifier
from labjoint.storage import RunWriter, open_run, read_run
from test_daemon_fixtures import BLOCK, FS, SHORT, make_daemon

GEOMETRY = ("bolt_radius_m", "contact_radius_m", "beam_mass_kg", "beam_support_stiffness_n_per_m",
            "beam_support_damping_ns_per_m", "torque_to_normal_n_per_nm")


def _config(rig=None, sim=None):
    over = {"daq": {"sample_rate_hz": FS, "block_samples": BLOCK}, "rig": dict(rig or {})}
    if sim:
        over["sim"] = {"seed": 0, **sim}
    return load_config(overrides=over)


def _engine_run(tmp_path, config, frequency_hz=400.0, vpp=4.0):
    """One dwell run through open_rig + RunEngine + RunWriter; its file."""
    data = tmp_path / "data"
    with open_rig(config) as rig:
        result = rig.engine([RunWriter(data)], sleep=lambda s: None).run(
            dwell(frequency_hz, vpp, **SHORT), name_prefix="")
    assert result.status == "complete"
    return data / f"{result.runs[0].name}.h5"


# ---- geometry in the config ------------------------------------------------------------

def test_rig_geometry_defaults_are_the_simulated_rigs_physics():
    sim, rig = SimConfig(), RigSection()
    assert rig.bolt_radius_m == sim.contact.bolt_radius_m
    assert rig.contact_radius == pytest.approx(sim.contact.contact_ratio * sim.contact.bolt_radius_m)
    assert rig.beam_mass_kg == sim.dynamics.beam_masses_kg[0]
    assert rig.beam_support_stiffness_n_per_m == sim.dynamics.support_stiffness_n_per_m
    assert rig.beam_support_damping_ns_per_m == sim.dynamics.support_damping_ns_per_m
    assert rig.torque_to_normal_n_per_nm == sim.contact.torque_to_normal_n_per_nm == 478.0
    for name in ("rig-sim.toml", "rig-real.toml"):
        assert load_config(CONFIG_DIR / name).rig.geometry() == rig.geometry()


@pytest.mark.parametrize("rig, field", [
    ({"bolt_radius_m": 0.0}, "rig.bolt_radius_m"),
    ({"beam_mass_kg": -1.0}, "rig.beam_mass_kg"),
    ({"beam_support_stiffness_n_per_m": -5.0}, "rig.beam_support_stiffness_n_per_m"),
    ({"contact_radius_m": 0.02}, "rig.contact_radius_m"),         # beyond 3.5 r_b = 17.5 mm
    ({"bolt_radius_m": 4e-3, "contact_radius_m": 3e-3}, "rig.contact_radius_m"),  # inside r_b
])
def test_bad_geometry_names_the_field(rig, field):
    with pytest.raises(ConfigError) as exc:
        load_config(overrides={"rig": rig})
    assert exc.value.field == field and "rig-sim.toml" in str(exc.value)


# ---- geometry through the engine into the pipelines --------------------------------------

def test_engine_writes_geometry_and_the_pipelines_read_it(tmp_path):
    cfg = _config({"bolt_radius_m": 4e-3, "contact_radius_m": 12e-3,
                   "torque_to_normal_n_per_nm": 500.0})
    path = _engine_run(tmp_path, cfg)
    with open_run(path) as rf:
        md = rf.metadata
    assert {k: md[k] for k in GEOMETRY} == cfg.rig.geometry()
    assert md["normal_force_n"] == pytest.approx(5.0 * 500.0)       # the sim's 5 Nm, this ratio
    # stick-slip: the contact geometry comes from the file, not the defaults
    run = read_run(path)
    ss = StickSlipIdentifier(0.168).fit(run).result_
    assert ss.contact.bolt_radius_m == 4e-3 and ss.contact.a == 12e-3
    assert ss.contact.normal_force_n == pytest.approx(2500.0)
    # a run that gives only the torque: the ratio from its metadata (not 478)
    run.metadata.pop("normal_force_n")
    ss = StickSlipIdentifier(0.168).fit(run).result_
    assert ss.contact.normal_force_n == pytest.approx(2500.0)


def test_calibration_takes_the_beam_dynamics_from_the_run(tmp_path):
    true = float(nanocomposite_true_factor(400.0))
    point = calibrate_run(_engine_run(tmp_path / "right", _config()))   # nothing typed in
    assert point.beam_mass_kg == 1.0
    assert point.n_per_v == pytest.approx(true, rel=0.02)
    # the same rig with a misstated beam mass in the config: the inertia is mis-removed
    wrong = calibrate_run(_engine_run(tmp_path / "wrong", _config({"beam_mass_kg": 0.5})))
    assert wrong.beam_mass_kg == 0.5 and abs(wrong.n_per_v / true - 1) > 0.05


def test_normal_force_precedence():
    md = {"torque_nm": 2.0, "normal_force_n": 900.0, "torque_to_normal_n_per_nm": 500.0}
    assert run_normal_force(md) == 900.0                                  # the file's value
    assert run_normal_force({**md, "normal_force_n": None}) == 1000.0     # torque x its ratio
    assert run_normal_force({"torque_nm": 2.0}) == 956.0                  # seed 002's 478
    assert run_normal_force(md, 400.0) == 800.0                           # stated ratio wins
    with pytest.raises(InputError) as exc:
        run_normal_force({"normal_force_n": 900.0}, 400.0)
    assert exc.value.field == "torque_nm"


# ---- which factor a run is read with ---------------------------------------------------

def test_channel_calibrations_say_which_points_the_factor_comes_from():
    spec = ChannelSpec("nc", "nanocomposite", "force", "N", 301.0,
                       calibration=((500.0, 300.0), (300.0, 280.0)))
    plain = ChannelSpec("f", "force", "force", "N", 50.0)
    src = {"nc": [{"frequency_hz": 300.0, "n_per_v": 280.0, "runs": ["cal300"]},
                  {"frequency_hz": 500.0, "n_per_v": 300.0, "runs": ["cal500"]}]}
    at = {f: channel_calibrations([spec, plain], f, src) for f in (300.0, 450.0, 800.0)}
    assert at[300.0]["nc"]["factor"] == 280.0 and at[300.0]["nc"]["interpolation"] == "exact"
    assert [p["runs"] for p in at[300.0]["nc"]["points"]] == [["cal300"]]
    assert at[450.0]["nc"]["factor"] == pytest.approx(295.0)
    assert [p["runs"] for p in at[450.0]["nc"]["points"]] == [["cal300"], ["cal500"]]
    assert at[800.0]["nc"]["factor"] == 300.0                             # held, and said so
    assert at[800.0]["nc"]["interpolation"].startswith("nearest")
    assert at[450.0]["f"] == {"factor": 50.0, "unit": "N/V", "frequency_hz": 450.0,
                              "source": "sensitivity", "interpolation": "none"}
    # a table typed into the config has no calibration run behind it
    (p,) = channel_calibrations([spec], 300.0)["nc"]["points"]
    assert p["source"].startswith("channel calibration table")
    json.dumps(at)                                                        # metadata-ready


# ---- the daemon applies stored calibrations ---------------------------------------------

def _ratio(path) -> tuple[float, dict]:
    """|F from the joint sensor| / |F_ref minus beam-1 inertia and support| at f."""
    with open_run(path) as rf:
        md, f, fs = rf.metadata, rf.frequency_hz, rf.sample_rate_hz
        ph = phasors(np.stack([rf.physical(c) for c in ("shear_nc", "force_ref", "disp_1")]), fs, f)
    nc, ref, x1 = ph[:, 0]
    w = 2 * np.pi * f
    dyn = md["beam_mass_kg"] * w ** 2 - md["beam_support_stiffness_n_per_m"] \
        - 1j * w * md["beam_support_damping_ns_per_m"]
    return float(abs(nc) / abs(ref + dyn * x1)), md


def test_daemon_applies_calibrations_stored_after_it_started(tmp_path):
    cfg = _config(sim={"sensors": {"nanocomposite": {"factor_n_per_v": 250.0}}})
    job_dwell = {"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 4.0, **SHORT}
    with make_daemon(tmp_path, cfg) as daemon:
        before = daemon.queue.submit(job_dwell)
        daemon.run_one()
        cal = daemon.queue.submit({"plan": "sensor_calibration", "frequencies_hz": [300.0, 400.0],
                                   "amplitude_vpp": 4.0, **SHORT, "n_cycles": 40})
        cal_runs = daemon.run_one().runs
        store = CalibrationStore.open(daemon.data_dir)
        points = calibrate_runs([daemon.data_dir / f"{r}.h5" for r in cal_runs], store)
        after = daemon.queue.submit(job_dwell)
        job = daemon.run_one()
        assert job.status == "done", job.message
        files = {k: daemon.data_dir / f"{daemon.queue.get(k).runs[0]}.h5" for k in (before, after)}
        # the DAQ itself carries the table (the safety checks read forces with it too)
        (nc,) = [c for c in daemon.rig.daq.channels if c.name == "shear_nc"]
        assert nc.calibration == store.table("shear_nc")
        # a broken store fails the next job with its name; the daemon goes on, output off
        (daemon.data_dir / "calibrations.json").write_text("{broken")
        daemon.queue.submit(job_dwell)
        failed = daemon.run_one()
        assert failed.status == "failed" and "calibrations.json" in failed.message
        assert daemon.rig.generator.read_settings().output is False
    assert [p.n_per_v for p in points] == pytest.approx([250.0, 250.0], rel=0.02)
    r_before, md_before = _ratio(files[before])
    r_after, md_after = _ratio(files[after])
    assert md_before["calibration"]["shear_nc"]["source"] == "sensitivity"
    assert r_before == pytest.approx(301.0 / 250.0, rel=0.03)
    used = md_after["calibration"]["shear_nc"]
    assert used["factor"] == pytest.approx(points[1].n_per_v) and used["frequency_hz"] == 400.0
    assert used["points"][0]["runs"] == [cal_runs[1]]
    assert used["points"][0]["store"] == str((daemon.data_dir / "calibrations.json").resolve())
    assert abs(r_after - 1) < 0.03
