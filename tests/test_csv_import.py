"""CSV import: exact round trip; every bad input names file, line and column, leaves nothing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.storage import Catalog, import_csv, open_run, read_run
from labjoint.storage import layout as layout_mod
from test_storage_fixtures import walk_nexus

FS = 1000.0
N = 40


def _rows(n: int = N, fs: float = FS) -> list[list[float]]:
    k = np.arange(n)
    t = k / fs
    u = 1e-5 * np.sin(2 * np.pi * 25 * t)
    f = 50.0 * np.sin(2 * np.pi * 25 * t + 0.4)
    a = 0.3 * np.cos(2 * np.pi * 25 * t)
    return [[float(x) for x in r] for r in zip(t, u, f, a)]


def _csv(tmp_path, rows=None, header="time_s,displacement_m,force_N,accel_g",
         meta=("# frequency_hz: 25", "# torque_nm: 5", "# operator: ms"), name="run.csv",
         fmt=repr, newline="\n"):
    lines = list(meta) + [header] + [",".join(fmt(x) for x in r) for r in (_rows() if rows is None else rows)]
    p = tmp_path / name
    p.write_text(newline.join(lines) + newline, newline="")
    return p


def _cell(p, line: int, col: int, value: str):
    lines = p.read_text().split("\n")
    cells = lines[line - 1].split(",")
    cells[col] = value
    lines[line - 1] = ",".join(cells)
    p.write_text("\n".join(lines))
    return p


def test_round_trip_is_exact(tmp_path):
    rows = np.array(_rows())
    src = _csv(tmp_path)
    cat = Catalog(tmp_path / "c.db")
    path = import_csv(src, tmp_path / "data", catalog=cat)
    assert path == tmp_path / "data" / "run.h5"
    run = read_run(path)
    assert np.array_equal(run.time, rows[:, 0])
    assert np.array_equal(run.displacement, rows[:, 1])
    assert np.array_equal(run.force, rows[:, 2])
    assert np.array_equal(run.channels["accel_g"], rows[:, 3])
    assert run.sample_rate_hz == pytest.approx(FS, rel=1e-12)
    assert run.metadata["frequency_hz"] == 25.0 and run.metadata["torque_nm"] == 5.0
    assert run.metadata["operator"] == "ms" and run.metadata["status"] == "complete"
    with open_run(path) as rf:
        specs = {c.name: c for c in rf.channels}
        assert specs["displacement"].unit == "m" and specs["force"].unit == "N"
        assert specs["accel_g"].quantity == "unknown" and specs["accel_g"].unit == ""  # a name is not a unit
        assert specs["accel_g"].sensor == "imported"
        assert all(c.sensitivity == 1.0 for c in rf.channels)
        assert rf.source == "imported"
    assert walk_nexus(path) == []
    assert [r.name for r in cat.query(torque_nm=5, source="imported")] == ["run"]


def test_parsed_csv_gives_the_same_run_as_the_imported_file(tmp_path):
    from labjoint.storage.csv_parse import parse_csv

    src = _csv(tmp_path)
    direct = parse_csv(src).to_run()
    stored = read_run(import_csv(src, tmp_path / "data"))
    for key in ("time", "displacement", "force"):
        assert np.array_equal(getattr(direct, key), getattr(stored, key))
    assert set(direct.channels) == set(stored.channels) == {"displacement", "force", "accel_g"}
    assert direct.sample_rate_hz == stored.sample_rate_hz and direct.metadata["torque_nm"] == 5.0


def test_metadata_rate_is_used_when_time_is_printed_coarsely(tmp_path):
    rows = _rows(300, fs=3000.0)
    src = _csv(tmp_path, rows, meta=("# sample_rate_hz: 3000",), fmt=lambda x: f"{x:.5f}")
    with open_run(import_csv(src, tmp_path / "d")) as rf:
        assert rf.sample_rate_hz == 3000.0
        assert rf.time().tolist() == [float(f"{k / 3000.0:.5f}") for k in range(300)]


def test_windows_line_endings_bom_quotes_and_spaces(tmp_path):
    rows = _rows(10)
    p = tmp_path / "win.csv"
    body = "\r\n".join(["# torque_nm : 3", '"time_s", "displacement_m" ,"force_N"']
                       + [", ".join(repr(x) for x in r[:3]) for r in rows]) + "\r\n\r\n"
    p.write_bytes(b"\xef\xbb\xbf" + body.encode())
    run = read_run(import_csv(p, tmp_path / "d", name="win-1"))
    assert np.array_equal(run.force, np.array(rows)[:, 2]) and run.metadata["torque_nm"] == 3.0


H = 4  # header line of the default file (after three metadata lines)


@pytest.mark.parametrize("case, line, column, message", [
    ("missing_column", H, "force_N", "missing column"),
    ("non_numeric", H + 3, "displacement_m", "not a number"),
    ("nan", H + 4, "force_N", "not a finite"),
    ("inf", H + 2, "accel_g", "not a finite"),
    ("repeated_time", H + 6, "time_s", "does not increase"),
    ("decreasing_time", H + 6, "time_s", "does not increase"),
    ("empty_file", 1, "time_s", "empty file"),
    ("only_metadata", H + 1, "time_s", "empty file"),
    ("no_rows", H + 1, "time_s", "no data rows"),
    ("one_row", H + 1, "time_s", "at least 2"),
    ("displacement_mm", H, "displacement_mm", "expected 'displacement_m'"),
    ("force_kN", H, "force_kN", "expected 'force_N'"),
    ("time_ms", H, "time_ms", "expected 'time_s'"),
    ("bad_metadata", 1, "frequency_hz", "abc"),
    ("negative_rate", 2, "sample_rate_hz", "positive"),
    ("rate_mismatch", 1, "sample_rate_hz", "disagrees"),
    ("drive_at_nyquist", 1, "frequency_hz", "Nyquist"),
    ("drive_above_nyquist", 1, "frequency_hz", "Nyquist"),
    ("metadata_with_equals", 2, "frequency_hz", "not with '='"),
    ("missing_sample", H + 11, "time_s", "irregular"),
    ("short_row", H + 5, "accel_g", "expected 4 values"),
    ("long_row", H + 5, "#5", "expected 4 values"),
    ("blank_line", H + 3, "time_s", "empty line"),
    ("duplicate_column", H, "force_N", "twice"),
    ("bad_column_name", H, "accel g", "letters"),
])
def test_bad_input_names_file_line_column_and_leaves_nothing(tmp_path, case, line, column, message):
    p = _bad(tmp_path, case)
    data_dir = tmp_path / "data"
    data_dir.mkdir()
    with pytest.raises(InputError, match=message) as ei:
        import_csv(p, data_dir)
    err = ei.value
    assert (err.file, err.line, err.column) == (str(p), line, column)
    assert str(p) in str(err) and f":{line}" in str(err) and column in str(err)
    assert list(data_dir.iterdir()) == []


def _bad(tmp_path, case: str):
    rows = _rows()
    if case == "missing_column":
        return _csv(tmp_path, [r[:2] for r in rows], header="time_s,displacement_m")
    if case == "non_numeric":
        return _cell(_csv(tmp_path), H + 3, 1, "abc")
    if case == "nan":
        return _cell(_csv(tmp_path), H + 4, 2, "nan")
    if case == "inf":
        return _cell(_csv(tmp_path), H + 2, 3, "-inf")
    if case == "repeated_time":
        rows[5][0] = rows[4][0]
        return _csv(tmp_path, rows)
    if case == "decreasing_time":
        rows[5][0] = rows[4][0] - 0.0005
        return _csv(tmp_path, rows)
    if case == "empty_file":
        p = tmp_path / "run.csv"
        p.write_text("")
        return p
    if case == "only_metadata":
        return _csv(tmp_path, [], header="# nothing else")
    if case == "no_rows":
        return _csv(tmp_path, [])
    if case == "one_row":
        return _csv(tmp_path, rows[:1])
    if case in ("displacement_mm", "force_kN", "time_ms"):
        header = "time_s,displacement_m,force_N,accel_g".replace(
            {"displacement_mm": "displacement_m", "force_kN": "force_N", "time_ms": "time_s"}[case], case)
        return _csv(tmp_path, header=header)
    if case == "bad_metadata":
        return _csv(tmp_path, meta=("# frequency_hz: abc",))
    if case == "negative_rate":
        return _csv(tmp_path, meta=("# torque_nm: 5", "# sample_rate_hz: -5", "# x: y"))
    if case == "rate_mismatch":
        return _csv(tmp_path, meta=("# sample_rate_hz: 2000", "# a: 1", "# b: 2"))
    if case == "drive_at_nyquist":                        # FS = 1000 Hz: Nyquist 500 Hz
        return _csv(tmp_path, meta=("# frequency_hz: 500", "# a: 1", "# b: 2"))
    if case == "drive_above_nyquist":
        return _csv(tmp_path, meta=("# frequency_hz: 4e3", "# a: 1", "# b: 2"))
    if case == "metadata_with_equals":                    # would be dropped as a comment
        return _csv(tmp_path, meta=("# a: 1", "# frequency_hz = 4e3", "# b: 2"))
    if case == "missing_sample":
        del rows[10]
        return _csv(tmp_path, rows)
    if case == "short_row":
        rows[4] = rows[4][:3]
        return _csv(tmp_path, rows)
    if case == "long_row":
        rows[4] = rows[4] + [1.0]
        return _csv(tmp_path, rows)
    if case == "blank_line":
        p = _csv(tmp_path)
        lines = p.read_text().split("\n")
        lines.insert(H + 2, "")
        p.write_text("\n".join(lines))
        return p
    if case == "duplicate_column":
        return _csv(tmp_path, header="time_s,displacement_m,force_N,force_N")
    if case == "bad_column_name":
        return _csv(tmp_path, header="time_s,displacement_m,force_N,accel g")
    raise AssertionError(case)


def test_failure_while_writing_leaves_no_file(tmp_path, monkeypatch):
    def broken(f, **kw):
        f.create_group("entry")
        raise OSError("disk full")

    monkeypatch.setattr(layout_mod, "create_layout", broken)
    with pytest.raises(OSError, match="disk full"):
        import_csv(_csv(tmp_path), tmp_path / "data")
    assert list((tmp_path / "data").iterdir()) == []


def test_existing_run_is_not_overwritten(tmp_path):
    src = _csv(tmp_path)
    path = import_csv(src, tmp_path / "data")
    before = path.read_bytes()
    with pytest.raises(InputError, match="already exists") as ei:
        import_csv(src, tmp_path / "data")
    assert ei.value.file == str(path) and path.read_bytes() == before
    other = import_csv(src, tmp_path / "data", name="run_b")
    assert other.name == "run_b.h5"
    with pytest.raises(InputError, match="run name"):
        import_csv(src, tmp_path / "data", name="../escape")


def test_irregular_tolerance_accepts_rounding_but_not_jitter(tmp_path):
    rows = _rows(200, fs=3000.0)
    ok = _csv(tmp_path, rows, meta=(), fmt=lambda x: f"{x:.5f}", name="ok.csv")  # +-0.5e-5 s on 3.3e-4 s
    assert math.isclose(read_run(import_csv(ok, tmp_path / "d")).sample_rate_hz, 3000.0, rel_tol=1e-3)
    rows[50][0] += 0.4 / 3000.0  # one stamp 40 % of a step late
    bad = _csv(tmp_path, rows, meta=(), name="bad.csv")
    with pytest.raises(InputError, match="irregular") as ei:
        import_csv(bad, tmp_path / "d")
    assert ei.value.line == 2 + 50  # header on line 1, row k on line 2 + k
