"""Files from other tools: TDMS and HDF5 import through a channel map, UFF 58 export."""

import json

import h5py
import numpy as np
import pytest
import pyuff
from nptdms import ChannelObject, TdmsWriter

from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.models.simulate import simulate
from labjoint.signal.frf import frf_h1
from labjoint.signal.uff_export import export_uff
from labjoint.storage import Run
from labjoint.storage.csv_import import import_parsed
from labjoint.storage.foreign import read_foreign
from labjoint.storage.reader import read_run

FS = 2048.0
MAP = """
[channels.displacement_m]
group = "Measurement"
channel = "Disp"
scale = 1e-6
[channels.force_N]
group = "Measurement"
channel = "Force"
[channels.accel_g]
group = "Measurement"
channel = "Accel"
[metadata]
frequency_hz = 80.0
torque_nm = 5.0
"""


def _tdms(path, n_force=4096):
    t = np.arange(4096) / FS
    disp_um = 12.0 * np.sin(2 * np.pi * 80 * t)
    force = 30.0 * np.sin(2 * np.pi * 80 * t + 0.3)
    props = {"wf_increment": 1 / FS, "unit_string": "um"}
    with TdmsWriter(str(path)) as w:
        w.write_segment([ChannelObject("Measurement", "Disp", disp_um, properties=props),
                         ChannelObject("Measurement", "Force", force[:n_force],
                                       properties={"wf_increment": 1 / FS}),
                         ChannelObject("Measurement", "Accel", 0.1 * disp_um,
                                       properties={"wf_increment": 1 / FS})])
    return disp_um, force


def test_a_labview_tdms_file_imports_in_si_units_with_its_metadata(tmp_path):
    disp_um, force = _tdms(tmp_path / "a.tdms")
    (tmp_path / "map.toml").write_text(MAP)
    parsed = read_foreign(tmp_path / "a.tdms", tmp_path / "map.toml")
    path = import_parsed(parsed, tmp_path / "data")
    run = read_run(path)
    assert run.sample_rate_hz == pytest.approx(FS)                      # from wf_increment
    np.testing.assert_allclose(run.displacement, disp_um * 1e-6, rtol=1e-12)
    np.testing.assert_allclose(run.force, force, rtol=1e-12)
    assert run.metadata["frequency_hz"] == 80.0 and run.metadata["torque_nm"] == 5.0
    assert "accel_g" in run.channels


def test_bad_foreign_files_are_refused_by_name_and_nothing_is_stored(tmp_path):
    _tdms(tmp_path / "short.tdms", n_force=4000)
    (tmp_path / "map.toml").write_text(MAP)
    with pytest.raises(InputError, match="unequal length"):
        read_foreign(tmp_path / "short.tdms", tmp_path / "map.toml")
    (tmp_path / "bad.toml").write_text(MAP.replace('"Force"', '"Load"'))
    _tdms(tmp_path / "a.tdms")
    with pytest.raises(InputError, match="no channel 'Measurement/Load'.*Force"):
        read_foreign(tmp_path / "a.tdms", tmp_path / "bad.toml")
    (tmp_path / "alias.toml").write_text(MAP.replace("80.0", "1500.0"))
    with pytest.raises(InputError, match="Nyquist"):
        read_foreign(tmp_path / "a.tdms", tmp_path / "alias.toml")
    assert main(["import", str(tmp_path / "short.tdms"), "--map", str(tmp_path / "map.toml"),
                 "--out", str(tmp_path / "data")]) == 2
    assert main(["import", str(tmp_path / "a.tdms"), "--out", str(tmp_path / "data")]) == 2
    assert not list((tmp_path / "data").glob("*.h5"))


def test_the_bouc_wen_benchmark_layout_imports_with_the_preset(tmp_path, capsys):
    u = np.random.default_rng(0).standard_normal((1000, 1))
    with h5py.File(tmp_path / "bw.h5", "w") as f:
        g = f.create_group("multisine")
        g["u"], g["y"], g["fs"] = u, 1e-4 * u, 750.0
    assert main(["import", str(tmp_path / "bw.h5"), "--map", "boucwen", "--out",
                 str(tmp_path / "data"), "--json"]) == 0
    run = read_run(json.loads(capsys.readouterr().out)["runs"][0])
    assert run.sample_rate_hz == 750.0 and run.force.size == 1000
    np.testing.assert_array_equal(run.force, u[:, 0])


LIN = {"inertia.m": 2.0, "viscous.c": 40.0, "linear_stiffness.k": 5e4}


def _receptance(f):
    w = 2 * np.pi * f
    return 1.0 / (LIN["linear_stiffness.k"] - LIN["inertia.m"] * w ** 2 + 1j * LIN["viscous.c"] * w)


def test_uff_export_holds_the_records_and_the_receptance_of_a_linear_oscillator(tmp_path, capsys):
    n, fs = 1024, 750.0
    rng = np.random.default_rng(4)
    fr = np.fft.rfftfreq(n, 1 / fs)
    spec = np.where((fr >= 5) & (fr <= 150), np.exp(2j * np.pi * rng.random(fr.size)), 0)
    F = np.tile(np.fft.irfft(spec, n) * 2e3, 8)
    y = simulate("inertia+viscous+linear_stiffness", LIN, F, fs)
    run = Run("lin", np.arange(F.size) / fs, y, F, {"sample_rate_hz": fs})
    res = export_uff(run, tmp_path / "lin.uff")
    sets = pyuff.UFF(str(tmp_path / "lin.uff")).read_sets()
    assert [s["func_type"] for s in sets] == [1, 1, 4, 6] and res["frf_lines"] == 198
    np.testing.assert_allclose(sets[1]["data"], F, rtol=1e-4, atol=1e-4 * np.abs(F).max())
    frf = sets[2]
    np.testing.assert_allclose(frf["data"], _receptance(frf["x"]), rtol=2e-3)
    assert np.all(sets[3]["data"] > 0.999)
    assert frf["rsp_node"] == 1 and frf["ref_node"] == 2


def test_welch_frf_of_a_random_record_matches_the_closed_form_where_coherent():
    fs, n = 750.0, 1 << 16
    F = np.random.default_rng(2).standard_normal(n) * 50
    y = simulate("inertia+viscous+linear_stiffness", LIN, F, fs)
    est = frf_h1(F, y, fs)
    assert "Welch" in est.method
    band = (est.freq_hz > 5) & (est.freq_hz < 150) & (est.coherence > 0.98)
    assert band.sum() > 100
    err = np.abs(est.h[band] / _receptance(est.freq_hz[band]) - 1)
    assert np.median(err) < 0.02


def test_cli_export_writes_one_file_per_run_into_a_directory(tmp_path, capsys):
    csv = tmp_path / "r.csv"
    t = np.arange(2000) / 1000.0
    rows = "\n".join(f"{a!r},{1e-6 * np.sin(2 * np.pi * 20 * a)!r},{np.sin(2 * np.pi * 20 * a)!r}"
                     for a in t.tolist()).replace("np.float64(", "").replace(")", "")
    csv.write_text("time_s,displacement_m,force_N\n" + rows + "\n")
    (tmp_path / "out").mkdir()
    assert main(["export", str(csv), "--uff", str(tmp_path / "out"), "--no-frf", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)["exported"][0]
    assert res["datasets"] == 2 and (tmp_path / "out" / "r.uff").is_file()
    assert main(["export", str(csv), str(csv), "--uff", str(tmp_path / "x.uff")]) == 2
