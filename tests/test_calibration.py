"""Nanocomposite sensor calibration against the reference force sensor (seed 002 III.B)."""

import json

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.identify.calibration import (CalibrationPoint, CalibrationStore, calibrate_run,
                                           calibrate_runs, calibration_factor, phasors)
from labjoint.storage import open_run, read_processed

FS, F = 50_000.0, 400.0


def _record(factor=301.0, m=0.8, k_s=2e5, c_s=150.0, seconds=0.5):
    t = np.arange(int(seconds * FS)) / FS
    w = 2 * np.pi * F
    x1 = 4e-6 * np.sin(w * t + 0.4)
    v1, a1 = 4e-6 * w * np.cos(w * t + 0.4), -w ** 2 * x1
    f_joint = 90 * np.sin(w * t) + 12 * np.sin(3 * w * t)       # a distorted joint force
    f_ref = f_joint + m * a1 + k_s * x1 + c_s * v1                # what the drive link carries
    volts = f_joint / factor + 1e-3 * np.random.default_rng(1).standard_normal(t.size)
    return volts, f_ref, x1


def test_phasor_of_a_sine_is_its_complex_amplitude():
    t = np.arange(5000) / FS
    x = 2.0 * np.cos(2 * np.pi * F * t - 0.3) + 0.5
    ph = phasors(x, FS, F, n_blocks=4)
    assert np.allclose(ph, 2.0 * np.exp(-0.3j), rtol=1e-9)


def test_factor_recovered_after_removing_beam_inertia_and_support():
    volts, f_ref, x1 = _record()
    p = calibration_factor(volts, f_ref, x1, FS, F, 0.8, support_stiffness_n_per_m=2e5,
                           support_damping_ns_per_m=150.0, runs=("r1",))
    assert p.n_per_v == pytest.approx(301.0, rel=1e-3)
    assert 0 < p.uncertainty < 0.3 and abs(p.phase_deg) < 0.1 and p.runs == ("r1",)
    naive = calibration_factor(volts, f_ref, x1, FS, F, 0.0)       # inertia not removed
    assert abs(naive.n_per_v / 301.0 - 1) > 0.05


def test_bad_calibration_inputs_name_the_parameter():
    volts, f_ref, x1 = _record()
    for kw, field in ((dict(beam_mass_kg=-1.0), "beam_mass_kg"),
                      (dict(beam_mass_kg=1.0, support_stiffness_n_per_m=-1.0),
                       "support_stiffness_n_per_m")):
        with pytest.raises(InputError) as exc:
            calibration_factor(volts, f_ref, x1, FS, F, **kw)
        assert exc.value.field == field
    with pytest.raises(InputError) as exc:
        calibration_factor(volts[:-5], f_ref, x1, FS, F, 1.0)
    assert exc.value.field == "sensor_volts"


def test_store_round_trip_fills_channel_spec_calibration(tmp_path):
    store = CalibrationStore.open(tmp_path)
    store.add("shear_nc", CalibrationPoint(400.0, 301.0, 0.2, runs=("a",)))
    store.add("shear_nc", CalibrationPoint(100.0, 290.0, 0.3, runs=("b",)))
    store.add("shear_nc", CalibrationPoint(400.0, 302.0, 0.1, runs=("c",)))   # replaces
    store.save()
    again = CalibrationStore.open(tmp_path / "calibrations.json")
    assert again.table("shear_nc") == ((100.0, 290.0), (400.0, 302.0))
    assert again.channels["shear_nc"][1].runs == ("c",)
    spec = ChannelSpec("shear_nc", "nanocomposite", "force", "N", 301.0)
    other = ChannelSpec("disp_1", "capacitive", "displacement", "m", 1.25e-5)
    filled, untouched = again.apply([spec, other])
    assert filled.units_per_volt(250.0) == pytest.approx(296.0)
    assert untouched == other
    assert json.loads((tmp_path / "calibrations.json").read_text())["channels"]["shear_nc"]["table"]
    (tmp_path / "calibrations.json").write_text("[]")
    with pytest.raises(InputError) as exc:
        CalibrationStore.open(tmp_path)
    assert "calibrations.json" in str(exc.value)


def test_calibration_run_on_the_simulated_rig_recovers_the_true_factor(tmp_path):
    from test_stickslip_simrig import write_sim_run
    from labjoint.hardware.sim.config import SimConfig
    from labjoint.hardware.sim.sensors import nanocomposite_true_factor

    dyn = SimConfig().dynamics
    paths = [write_sim_run(tmp_path, f"cal{f:g}", f, 10.0, 5.0, seconds=0.2) for f in (100.0, 400.0)]
    store = CalibrationStore.open(tmp_path)
    points = calibrate_runs(paths, store, beam_mass_kg=dyn.beam_masses_kg[0],
                            support_stiffness_n_per_m=dyn.support_stiffness_n_per_m,
                            support_damping_ns_per_m=dyn.support_damping_ns_per_m)
    for p in points:
        true = float(nanocomposite_true_factor(p.frequency_hz))
        assert p.n_per_v == pytest.approx(true, rel=0.02)
    assert CalibrationStore.open(tmp_path).factor("shear_nc", 400.0) == pytest.approx(
        float(nanocomposite_true_factor(400.0)), rel=0.02)
    arrays, attrs = read_processed(paths[1], "calibration")
    assert float(arrays["factor"]) == pytest.approx(points[1].n_per_v)
    assert attrs["channel"] == "shear_nc"
    # without the beam mass the inertia would be calibrated in: refused
    with pytest.raises(InputError) as exc:
        calibrate_run(paths[1])
    assert exc.value.field == "beam_mass_kg"


def test_clipped_calibration_run_is_refused(tmp_path):
    from test_stickslip_simrig import write_sim_run
    path = write_sim_run(tmp_path, "loud", 200.0, 20.0, 5.0, seconds=0.1)   # near resonance
    with open_run(path) as rf:
        assert np.abs(rf.volts("force_ref")).max() >= 0.999 * 5.0
    with pytest.raises(InputError) as exc:
        calibrate_run(path, beam_mass_kg=1.0)
    assert "clipped" in str(exc.value)
