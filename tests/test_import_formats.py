"""Import what labs export through one channel map: CSV, MATLAB v5 and v7.3, UFF 58
(time records and FRFs), TDMS, multi-test HDF5 and a directory with a metadata table.
Every file holds a record with known closed-form samples in lab units (mV, mm/s, g,
ms); the run files must hold them in SI with the right quantity, unit and role."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
import pyuff
import scipy.io
from nptdms import ChannelObject, TdmsWriter

import importgen as g
from labjoint.cli.main import main
from labjoint.storage.importers import read_frf
from labjoint.storage.reader import read_channels


def _import(capsys, *argv) -> dict:
    assert main(["import", *map(str, argv), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _check_si(path, rtol=1e-12):
    rec = read_channels(path)
    assert rec.sample_rate_hz == pytest.approx(g.FS, rel=max(rtol, 1e-12))
    np.testing.assert_allclose(rec.time, g.T, atol=1e-12 + 10 * rtol)
    expect = {"drive": ("voltage", "V", "drive", g.VOLTS),
              "laser": ("velocity", "m/s", "response", g.VELOCITY),
              "acc": ("acceleration", "m/s^2", "response", g.ACCEL)}
    for name, (q, u, role, truth) in expect.items():
        c = rec.channel(name)
        assert (c.quantity, c.units, c.role) == (q, u, role)
        np.testing.assert_allclose(c.samples, truth, rtol=rtol, atol=1e-15)
    with h5py.File(path) as f:
        for name, (q, u, _, _) in expect.items():
            a = f[f"entry/data/{name}"].attrs
            assert (a["quantity"], a["units"]) == (q, u)
    return rec


def test_a_csv_with_a_map_is_converted_to_si_never_ignored(tmp_path, capsys):
    src = g.write_csv(tmp_path / "sweep 1.csv", header="# operator: ana\n# frequency_hz: 8\n")
    mp = g.write_map(tmp_path / "lab.toml")
    out = _import(capsys, src, "--map", mp, "--out", tmp_path / "data")
    assert [p.rsplit("/", 1)[1] for p in out["runs"]] == ["sweep_1.h5"]
    rec = _check_si(out["runs"][0], rtol=1e-14)
    assert rec.metadata["frequency_hz"] == 8.0 and rec.metadata["operator"] == "ana"
    assert rec.metadata["drive_channels"] == ["drive"]
    assert rec.metadata["response_channels"] == ["laser", "acc"]


def test_mat_v5_structs_one_run_per_test(tmp_path, capsys):
    tests = {"sine_8Hz": g.lab_columns(), "sine_8Hz_high": g.lab_columns(2.0)}
    scipy.io.savemat(tmp_path / "lab.mat", {k: {**v, "torque": 5.0} for k, v in tests.items()})
    mp = g.write_map(tmp_path / "m.toml", '[tests]\ninclude = ["sine_*"]\n'
                     '[metadata.attrs]\ntorque_nm = "torque"\n')
    out = _import(capsys, tmp_path / "lab.mat", "--map", mp, "--out", tmp_path / "data")
    assert sorted(p.rsplit("/", 1)[1] for p in out["runs"]) == ["sine_8Hz.h5", "sine_8Hz_high.h5"]
    _check_si(tmp_path / "data" / "sine_8Hz.h5")
    high = read_channels(tmp_path / "data" / "sine_8Hz_high.h5")
    np.testing.assert_allclose(high.channel("laser").samples, 2 * g.VELOCITY, rtol=1e-12)
    assert high.metadata["torque_nm"] == 5.0


def test_mat_v73_variables_read_through_h5py(tmp_path, capsys):
    g.write_mat73(tmp_path / "big.mat", {"run7": g.lab_columns()})
    mp = g.write_map(tmp_path / "m.toml", '[tests]\ninclude = ["run*"]\n')
    out = _import(capsys, tmp_path / "big.mat", "--map", mp, "--out", tmp_path / "data")
    _check_si(out["runs"][0])


def _uff_time(path, cols, with_frf=False):
    u = pyuff.UFF(str(path))
    sets = []
    for k, (name, data) in enumerate(cols.items()):
        sets.append(pyuff.prepare_58(
            func_type=1, rsp_node=k + 1, rsp_dir=3, ref_node=1, ref_dir=3, id1=name,
            data=np.asarray(data, float), x=g.T.copy(), ord_data_type=4, abscissa_spacing=1,
            abscissa_spec_data_type=17, ordinate_spec_data_type=0, orddenom_spec_data_type=0,
            z_axis_spec_data_type=0, binary=0))
    if with_frf:
        f = np.linspace(1.0, 100.0, 100)
        h = 1.0 / (100.0**2 - f**2 + 2j * 0.02 * 100.0 * f)       # a mobility per mV, by hand
        sets.append(pyuff.prepare_58(
            func_type=4, rsp_node=2, rsp_dir=3, ref_node=1, ref_dir=3, id1="H_laser_drive",
            data=h, x=f, ord_data_type=6, abscissa_spacing=1, abscissa_spec_data_type=18,
            ordinate_spec_data_type=11, orddenom_spec_data_type=0, z_axis_spec_data_type=0,
            binary=0))
    u.write_sets(sets, mode="overwrite")
    return path


def test_uff58_time_records_and_frfs(tmp_path, capsys):
    cols = {k: v for k, v in g.lab_columns().items() if k != "t"}
    src = _uff_time(tmp_path / "shake.uff", cols, with_frf=True)
    mp = g.write_map(tmp_path / "m.toml", '[frf]\nresponse = {name = "laser", quantity = '
                     '"velocity", units = "mm/s"}\ndrive = {name = "drive", quantity = '
                     '"voltage", units = "mV"}\n')
    text = mp.read_text().replace('[time]\nsource = "t"\nunits = "ms"\n', "")
    mp.write_text(text)
    out = _import(capsys, src, "--map", mp, "--out", tmp_path / "data")
    rec = _check_si(out["runs"][0], rtol=5e-6)           # UFF ASCII keeps ~6 digits
    assert rec.metadata["record"] == "time+frf"
    frf = read_frf(out["runs"][0])
    f = np.linspace(1.0, 100.0, 100)
    h = 1.0 / (100.0**2 - f**2 + 2j * 0.02 * 100.0 * f)
    assert frf.units == "m/s/V" and frf.response_quantity == "velocity"
    np.testing.assert_allclose(frf.h[0], h * 1e-3 / 1e-3, rtol=1e-5)    # (mm/s)/mV = (m/s)/V


def test_tdms_groups_and_hdf5_groups_select_tests_by_pattern(tmp_path, capsys):
    cols = g.lab_columns()
    props = {"wf_increment": 1 / g.FS}
    with TdmsWriter(str(tmp_path / "daq.tdms")) as w:
        w.write_segment([ChannelObject(grp, k, v * s, properties=props)
                         for grp, s in (("Test_A", 1.0), ("Test_B", 3.0)) for k, v in cols.items()
                         if k != "t"])
    mp = g.write_map(tmp_path / "m.toml", '[tests]\ninclude = ["Test_*"]\nskip = ["Test_B"]\n')
    mp.write_text(mp.read_text().replace('source = "t"\nunits = "ms"', ""))
    out = _import(capsys, tmp_path / "daq.tdms", "--map", mp, "--out", tmp_path / "d1")
    assert [p.rsplit("/", 1)[1] for p in out["runs"]] == ["Test_A.h5"]
    assert out["skipped"][0]["test"] == "Test_B"
    _check_si(out["runs"][0])
    with h5py.File(tmp_path / "multi.h5", "w") as f:
        for name in ("Sine_A", "Sine_B", "calib"):
            grp = f.create_group(name)
            for k, v in cols.items():
                grp[k] = v.astype(np.float32) if k != "t" else v
    mp2 = g.write_map(tmp_path / "m2.toml", '[tests]\ninclude = ["Sine_*"]\n')
    out = _import(capsys, tmp_path / "multi.h5", "--map", mp2, "--out", tmp_path / "d2")
    assert sorted(p.rsplit("/", 1)[1] for p in out["runs"]) == ["Sine_A.h5", "Sine_B.h5"]
    _check_si(out["runs"][0], rtol=1e-6)                 # float32 columns


def test_a_directory_with_one_map_and_a_metadata_table(tmp_path, capsys):
    d = tmp_path / "export"
    d.mkdir()
    for i, s in enumerate((1.0, 2.0, 4.0)):
        g.write_csv(d / f"level{i}.csv", g.lab_columns(s))
    (tmp_path / "tests.csv").write_text("file,frequency_hz,level,torque_nm\n"
                                        "level0.csv,8,0.1,5\nlevel1.csv,8,0.2,5\nlevel2,8.0,0.4,7.5\n")
    mp = g.write_map(tmp_path / "m.toml")
    out = _import(capsys, d, "--map", mp, "--table", tmp_path / "tests.csv", "--out", tmp_path / "data")
    assert len(out["runs"]) == 3
    recs = {p.rsplit("/", 1)[1]: read_channels(p) for p in out["runs"]}
    assert [recs[f"level{i}.h5"].metadata["level"] for i in range(3)] == [0.1, 0.2, 0.4]
    assert recs["level2.h5"].metadata["torque_nm"] == 7.5
    assert recs["level1.h5"].metadata["frequency_hz"] == 8.0
    np.testing.assert_allclose(recs["level2.h5"].channel("acc").samples, 4 * g.ACCEL, rtol=1e-12)


def _uff_frfs(path, hs, f):
    sets = [pyuff.prepare_58(func_type=4, rsp_node=k + 2, rsp_dir=3, ref_node=1, ref_dir=3,
                             id1=f"Pt{k + 2}:+Z/Pt1:+Z", data=h, x=f, ord_data_type=6,
                             abscissa_spacing=1, abscissa_spec_data_type=18,
                             ordinate_spec_data_type=12, orddenom_spec_data_type=13,
                             z_axis_spec_data_type=0, binary=0) for k, h in enumerate(hs)]
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path


def test_an_frf_only_uff_file_is_stored_in_si_with_its_quantity_pair(tmp_path, capsys):
    f = np.linspace(2.0, 200.0, 199)
    w, wn = 2 * np.pi * f, 2 * np.pi * np.array([[40.0], [130.0]])
    hs = -w**2 / (wn**2 - w**2 + 2j * 0.01 * wn * w) / 9.80665 / 2.0     # accelerance in g/N, by hand
    src = _uff_frfs(tmp_path / "impact.uff", hs, f)
    mp = tmp_path / "m.toml"
    mp.write_text('[frf]\nestimator = "H1"\nresponse = {quantity = "acceleration", units = "g"}\n'
                  'drive = {name = "hammer", quantity = "force", units = "N"}\n')
    out = _import(capsys, src, "--map", mp, "--out", tmp_path / "data")
    frf = read_frf(out["runs"][0])
    assert (frf.units, frf.estimator, frf.drive) == ("m/s^2/N", "H1", "hammer")
    assert frf.responses == ["Pt2_Z_Pt1_Z", "Pt3_Z_Pt1_Z"]
    np.testing.assert_allclose(frf.h, hs * 9.80665, rtol=1e-5)
    np.testing.assert_allclose(frf.frequency_hz, f, rtol=1e-6)
    rec = read_channels(out["runs"][0])
    assert rec.metadata["record"] == "frf" and rec.drive("force").units == "N"
    assert [c.quantity for c in rec.responses] == ["acceleration", "acceleration"]
    mp.write_text(mp.read_text().replace(', units = "g"', ""))
    assert main(["import", str(src), "--map", str(mp), "--out", str(tmp_path / "d2")]) == 2
    assert "frf.response" in capsys.readouterr().err


def test_a_joint_record_in_lab_units_feeds_the_joint_pipelines(tmp_path, capsys):
    x_um, f_kn = 5.0 * np.sin(2 * np.pi * 8.0 * g.T), 0.3 * np.cos(2 * np.pi * 8.0 * g.T)
    src = g.write_csv(tmp_path / "joint.csv", {"t_s": g.T, "rel_um": x_um, "F_kN": f_kn})
    mp = tmp_path / "m.toml"
    mp.write_text('[time]\nsource = "t_s"\n[channels.x]\nsource = "rel_um"\nquantity = "displacement"\n'
                  'units = "\u00b5m"\n[channels.F]\nsource = "F_kN"\nquantity = "force"\nunits = "kN"\n'
                  'role = "drive"\n[metadata]\nfrequency_hz = 8.0\ndisplacement_channels = ["x"]\n'
                  'joint_force_channel = "F"\n')
    out = _import(capsys, src, "--map", mp, "--out", tmp_path / "data")
    from labjoint.storage import read_run
    run = read_run(out["runs"][0])
    np.testing.assert_allclose(run.displacement, x_um * 1e-6, rtol=1e-14)
    np.testing.assert_allclose(run.force, f_kn * 1e3, rtol=1e-14)
