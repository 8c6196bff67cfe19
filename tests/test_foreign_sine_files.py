"""Run files rather than CSV: a differential pair of displacement probes (the rig's
disp_1 - disp_2) and a CSV brought in by ``labjoint import`` then analysed from HDF5,
with the independent generator's closed forms (W = pi c omega U^2, C = c, k)."""

import json

import numpy as np
import pytest

from foreign_sine import Record, write_csv
from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.identify.analyze import analyze_file
from test_storage_fixtures import FS, quantise, write_run

# 400 Hz: the nanocomposite sensor's calibration is 301 N/V there (test_storage_fixtures)
JOINT = Record(f=400.0, fs=FS, cycles=40, k=1.2e7, c=400.0, U=4e-6)


def pair_volts(r: Record, clip_disp_1_v: float | None = None) -> np.ndarray:
    """(force_ref, disp_1, disp_2, shear_nc) volts: each probe sees half the motion on
    its own gap, the joint force through the 301 N/V sensor."""
    t, u, F = r.arrays()
    d1 = (0.5 * u + 40e-6) / 1.25e-5                    # probes: 12.5 um/V, own gaps
    d2 = (-0.5 * u + 25e-6) / 1.25e-5
    if clip_disp_1_v is not None:
        d1 = np.minimum(d1, clip_disp_1_v)
    return quantise(np.stack([F / 50.0, d1, d2, F / 301.0]))


def test_a_differential_pair_gives_the_closed_form(tmp_path, capsys):
    path = write_run(tmp_path, "pair", pair_volts(JOINT))
    s = analyze_file(path).summary
    assert s["energy_loss_j"] == pytest.approx(JOINT.energy_loss, rel=3e-3)
    assert s["damping_ns_per_m"] == pytest.approx(JOINT.c, rel=3e-3)
    assert s["stiffness_n_per_m"] == pytest.approx(JOINT.k, rel=2e-3)
    assert s["displacement_amplitude_m"] == pytest.approx(JOINT.U, rel=2e-3)
    assert main(["analyze", str(path), "--json"]) == 0
    row = json.loads(capsys.readouterr().out)["runs"][0]
    assert row["energy_loss_j"] == pytest.approx(s["energy_loss_j"], rel=1e-9)


def test_one_clipped_probe_of_the_pair_is_refused_by_name(tmp_path):
    # disp_1 reaches 3.36 V; its input saturates at 3.3 V. The difference disp_1 - disp_2
    # has no flat top (disp_2 keeps moving), so the check is made on each probe
    path = write_run(tmp_path, "clip1", pair_volts(JOINT, clip_disp_1_v=3.3))
    with pytest.raises(InputError, match="clipped") as exc:
        analyze_file(path)
    assert exc.value.field == "disp_1"


def test_an_imported_csv_analyses_the_same_from_its_run_file(tmp_path, capsys):
    r = Record(f=233.7, fs=51200.0, cycles=20, noise_u=2.5e-8, noise_f=0.05, offset_u=2e-5)
    csv = write_csv(tmp_path / "lab.csv", *r.arrays(), {"torque_nm": 4, "operator": "x"})
    assert main(["import", str(csv), "--out", str(tmp_path / "data"), "--json"]) == 0
    capsys.readouterr()
    h5 = tmp_path / "data" / "lab.h5"
    assert main(["analyze", str(h5), str(csv), "--json"]) == 0
    from_h5, from_csv = json.loads(capsys.readouterr().out)["runs"]
    assert abs(from_h5["energy_loss_j"] - r.energy_loss) < 4 * from_h5["energy_loss_j_uncertainty"]
    assert from_h5["stiffness_n_per_m"] == pytest.approx(r.k, rel=2e-3)
    for key in ("energy_loss_j", "damping_ns_per_m", "stiffness_n_per_m"):
        assert from_h5[key] == pytest.approx(from_csv[key], rel=1e-6)


def test_an_imported_clipped_csv_is_kept_but_its_analysis_refused(tmp_path, capsys):
    t, u, F = Record(cycles=20).arrays()
    csv = write_csv(tmp_path / "clip.csv", t, u, np.clip(F, -8.0, 8.0))
    assert main(["import", str(csv), "--out", str(tmp_path / "data"), "--json"]) == 0
    capsys.readouterr()                                  # raw data is stored as measured
    assert main(["analyze", str(tmp_path / "data" / "clip.h5"), "--json"]) != 0
    out, err = capsys.readouterr()
    assert out == "" and "clipped" in err and "force" in err
