"""Issue 33's attack pass on this wave's commands: numbers no measurement in SI units
holds (a column in other units: 1e295 "m", 1e302 "N", 1e-305 "m") went through
`import` and then ended `analyze`, `fit` and `distortion` in tracebacks (OverflowError,
IndexError, ZeroDivisionError) or in numpy warnings. Each must be one line naming the
file and the channel, exit 2."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.storage import import_csv

FS, F_HZ = 2000.0, 50.0


def _csv(path, u_scale=1.0, f_scale=1.0):
    t = np.arange(4000) / FS
    u = 1e-5 * np.sin(2 * np.pi * F_HZ * t)
    F = 1e7 * u + 5 * np.cos(2 * np.pi * F_HZ * t)
    with open(path, "w") as fh:
        fh.write(f"# frequency_hz: {F_HZ}\n# sample_rate_hz: {FS}\n")
        fh.write("time_s,displacement_m,force_N\n")
        np.savetxt(fh, np.column_stack([t, u * u_scale, F * f_scale]), fmt="%.10g",
                   delimiter=",")
    return path


CASES = {"huge_displacement": ({"u_scale": 1e300}, "displacement", "too large to square"),
         "huge_force": ({"f_scale": 1e300}, "force", "too large to square"),
         "tiny_displacement": ({"u_scale": 1e-300}, "displacement", "femtometre")}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("command", [["analyze"], ["fit", "--model", "linear_stiffness+viscous"],
                                     ["distortion"]])
def test_a_column_in_other_units_is_one_line_and_exit_2(tmp_path, capsys, case, command):
    scale, channel, words = CASES[case]
    csv = _csv(tmp_path / f"{case}.csv", **scale)
    h5 = import_csv(csv, tmp_path / "data")
    if command == ["distortion"] and case == "tiny_displacement":
        pytest.skip("a femtometre-scale displacement's harmonic ratios are still ratios")
    code = main([command[0], str(h5), *command[1:], "--json"])
    out = capsys.readouterr()
    assert code == 2, out
    assert out.out == ""
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.err, out.err
    assert str(h5) in lines[0] and words in lines[0], lines[0]
    if command[0] != "distortion":       # distortion names the drive's channel ('signal')
        assert channel in lines[0]


def _bert_like(path, dtype_laser=None):
    import h5py
    t = np.arange(4000) / FS
    x = np.sin(2 * np.pi * 20 * t)
    with h5py.File(path, "w") as f:
        g = f.create_group("T1")
        g.attrs["sample_rate_hz"] = FS
        g["time_s"], g["input_V"] = t, x
        g["laser_m_per_s"] = np.array([b"a"] * t.size) if dtype_laser == "S" else 1e-3 * x
        for k in range(1, 5):
            g[f"acc{k}_m_per_s2"] = x
    return path


def _map(tmp_path, quantity="velocity"):
    from pathlib import Path
    text = Path(__file__).resolve().parents[1].joinpath("configs", "maps", "bert.toml").read_text()
    text = text.replace('include = ["Sine_*", "Rand_*"]', 'include = ["T*"]')
    text = text.replace('quantity = "velocity"', f'quantity = "{quantity}"', 1)
    p = tmp_path / "map.toml"
    p.write_text(text)
    return p


def test_a_misspelt_quantity_with_a_known_unit_is_refused_not_stored_unconverted(tmp_path, capsys):
    # 'velocty' with m/s was kept as an unknown quantity in its unit as given
    src = _bert_like(tmp_path / "t.h5")
    code = main(["import", str(src), "--map", str(_map(tmp_path, "velocty")),
                 "--out", str(tmp_path / "out"), "--json"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "velocty" in err[0] and "write quantity = 'velocity'" in err[0]
    assert not list((tmp_path / "out").glob("*.h5"))


def test_a_text_channel_is_not_called_complex(tmp_path, capsys):
    src = _bert_like(tmp_path / "t.h5", dtype_laser="S")
    code = main(["import", str(src), "--map", str(_map(tmp_path)), "--out",
                 str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "laser_m_per_s" in err[0] and "complex" not in err[0] and "not real numbers" in err[0]


@pytest.mark.parametrize("where", ["dir", "missing"])
def test_frf_out_that_cannot_be_written_is_refused_before_any_work(tmp_path, capsys, where):
    # `frf --out /tmp` ended in IsADirectoryError after writing '/.tmp.tmp' beside it;
    # a missing directory in FileNotFoundError
    out = tmp_path if where == "dir" else tmp_path / "no" / "x.json"
    code = main(["frf", str(tmp_path / "any.h5"), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "Traceback" not in err[0]
    assert ("is a directory" if where == "dir" else "does not exist") in err[0]
    assert not list(tmp_path.parent.glob(".*.tmp"))


def test_a_garbage_tdms_file_is_one_line_naming_it_unreadable(tmp_path, capsys):
    # nptdms logged two warnings to stderr and the file was then "no test matches"
    src = tmp_path / "g.tdms"
    src.write_bytes(b"TDSm" + bytes(range(256)) * 2)
    text = _map(tmp_path).read_text().replace('format = "hdf5"', 'format = "tdms"')
    (tmp_path / "map.toml").write_text(text)
    code = main(["import", str(src), "--map", str(tmp_path / "map.toml"), "--out",
                 str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "not a readable TDMS file" in err[0] and str(src) in err[0]
