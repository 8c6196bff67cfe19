"""Bad input at the CLI (issue 33 item 18): simulate --plan through the admission check,
an unknown structure --set key, 1,000 copies of one run at recover, and the like. Each
gives one clear line (exit 2) or a report, never a traceback or a silent wrong answer."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from labjoint.cli.main import main
from labjoint.storage import Catalog
from test_storage_fixtures import FS, write_run

ROOT = Path(__file__).resolve().parents[1]
SEED000 = str(ROOT / "configs" / "structure-seed000.toml")
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
MAIN = "import sys; from labjoint.cli.main import main; sys.exit(main())"


def test_simulate_plan_is_refused_by_the_admission_check_before_anything_runs(tmp_path,
                                                                               capsys):
    out = tmp_path / "d"
    over = tmp_path / "over.toml"            # first: on a build without the check it ends
    over.write_text('plan = "dwell"\nfrequency_hz = 400.0\namplitude_vpp = 50.0\n')
    assert main(["simulate", "--plan", str(over), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(over) in err and "max_vpp" in err and err.count("\n") == 1
    assert not out.exists()                                   # nothing written
    plan = tmp_path / "long.toml"
    plan.write_text('plan = "dwell"\nfrequency_hz = 400.0\namplitude_vpp = 1.0\n'
                    'n_cycles = 1000000000000\n')            # 1e12 cycles: 79 years
    assert main(["simulate", "--plan", str(plan), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(plan) in err and "max_record_s" in err and err.count("\n") == 1
    assert not out.exists()


def test_structure_set_of_an_unknown_parameter_is_refused_naming_it(capsys):
    assert main(["structure", "modes", SEED000, "--set", "UNKNOWN=5", "--json"]) == 2
    err = capsys.readouterr().err
    assert "UNKNOWN" in err and "E_e_pa" in err and err.count("\n") == 1


def test_copies_of_one_run_are_reported_once_and_not_added_again(tmp_path, capsys):
    t = np.arange(1000) / FS
    src = write_run(tmp_path, "orig", np.vstack([np.sin(2 * np.pi * 400 * t)] * 4) * 0.1)
    for k in range(300):
        shutil.copy(src, tmp_path / f"copy_{k:04d}.h5")
    reports, times = [], []
    for _ in range(2):
        t0 = time.perf_counter()
        assert main(["recover", "--data", str(tmp_path), "--json"]) == 0
        times.append(time.perf_counter() - t0)
        reports.append(json.loads(capsys.readouterr().out))
    first, second = reports
    assert first["added_to_catalog"] == ["orig"] and second["added_to_catalog"] == []
    assert [len(v) for v in second["copies_not_indexed"].values()] == [300]
    held = Catalog(tmp_path / "catalog.sqlite").get("orig").path   # one file: the first
    assert held not in second["copies_not_indexed"]["orig"] and Path(held).exists()
    assert main(["recover", "--data", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert sum("300 copies of run orig" in ln for ln in lines) == 1 and len(lines) == 1


def _cli_bytes(*args: bytes) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable.encode(), b"-c", MAIN.encode(), *args], env=ENV,
                          capture_output=True, timeout=300)


def test_binary_bytes_are_escaped_not_echoed_raw(tmp_path):
    """A file name or a value carrying ESC sequences and non-UTF-8 bytes: the terminal
    gets them escaped (\\x1b, \\xff), on stdout and stderr."""
    r = _cli_bytes(b"structure", b"modes", SEED000.encode(), b"--set", b"\x1b[2J\xff=5")
    assert r.returncode == 2 and b"\x1b" not in r.stderr and b"\xff" not in r.stderr
    assert b"\\x1b[2J\\xff" in r.stderr and r.stderr.count(b"\n") == 1
    d = tmp_path / "d"
    d.mkdir()
    bad = os.path.join(os.fsencode(d), b"run\x1b[31m\xff.h5")
    with open(bad, "wb") as fh:
        fh.write(b"\x89HDF\r\n\x1a\n" + bytes(range(256)) * 4)    # a header, then garbage
    r = _cli_bytes(b"recover", b"--data", os.fsencode(d))
    assert r.returncode == 0, r.stderr
    assert b"\x1b" not in r.stdout + r.stderr and b"\xff" not in r.stdout + r.stderr
    assert b"run\\x1b[31m\\xff.h5" in r.stdout


def _model_file(tmp_path, **change):
    d = {"format": "labjoint-model/1", "model": "inertia+viscous+linear_stiffness",
         "structure": "sdof", "substeps": 20,
         "parameters": {"inertia.m": {"value": 2.0}, "viscous.c": {"value": 10.0},
                        "linear_stiffness.k": {"value": 5e4}}}
    d.update(change)
    p = tmp_path / "m.json"
    p.write_text(json.dumps(d))
    return p


def test_bad_model_files_are_one_line_naming_the_field(tmp_path, capsys):
    from labjoint.compare.model_file import FORMAT, load_model

    assert FORMAT == "labjoint-model/1"
    load_model(_model_file(tmp_path))                       # the good one loads
    rec = tmp_path / "r.csv"
    rec.write_text("time_s,displacement_m,force_N\n" + "".join(
        f"{k / 1000},{1e-6 * np.sin(k / 5)},{np.cos(k / 5)}\n" for k in range(400)))
    for change, field in (({"substeps": "abc"}, "substeps"), ({"substeps": 1e15}, "substeps"),
                          ({"substeps": 10**15}, "substeps"), ({"substeps": True}, "substeps"),
                          ({"parameters": [1, 2, 3]}, "parameters")):
        m = _model_file(tmp_path, **change)
        t0 = time.perf_counter()
        assert main(["predict", str(m), str(rec), "--json"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and str(m) in err and field in err, err


def test_a_structure_of_micrometre_elements_is_refused_before_assembly(tmp_path, capsys):
    text = Path(SEED000).read_text()
    assert "element_length_m = 0.02" in text
    s = tmp_path / "fine.toml"
    s.write_text(text.replace("element_length_m = 0.02", "element_length_m = 1.6e-6"))
    assert main(["structure", "modes", str(s), "--json"]) == 2
    err = capsys.readouterr().err
    assert "element_length_m" in err and err.count("\n") == 1


def _boucwen_file(p, u, y=None):
    import h5py

    with h5py.File(p, "w") as f:
        g = f.create_group("multisine")
        g["u"] = u
        if y is None:
            g["y"] = 1e-4 * u
        else:
            g.create_dataset("y", **y)
        g["fs"] = 750.0
    return p


def test_an_hdf5_declaring_1e9_samples_is_refused_before_it_is_read(tmp_path, capsys):
    big = _boucwen_file(tmp_path / "big.h5", np.zeros((1000, 1)),
                        {"shape": (10**9, 1), "dtype": "f8", "chunks": (65536, 1)})
    assert big.stat().st_size < 1e6                     # declared, never written
    t0 = time.perf_counter()
    assert main(["import", str(big), "--map", "boucwen", "--out", str(tmp_path / "d"),
                 "--json"]) == 2
    err = capsys.readouterr().err
    assert str(big) in err and "1e+09" in err and err.count("\n") == 1
    assert not list((tmp_path / "d").glob("*.h5")) if (tmp_path / "d").exists() else True


def test_a_complex_channel_is_refused_not_truncated(tmp_path, capsys):
    u = np.random.default_rng(0).standard_normal((1000, 1))
    p = _boucwen_file(tmp_path / "c.h5", u, {"data": (1e-4 * u) * (1 + 1j)})
    assert main(["import", str(p), "--map", "boucwen", "--out", str(tmp_path / "d"),
                 "--json"]) == 2
    err = capsys.readouterr().err
    assert "complex" in err and str(p) in err and err.count("\n") == 1


def test_a_run_file_declaring_1e9_samples_is_refused_before_it_is_read_whole(tmp_path, capsys):
    import h5py

    t = np.arange(2000) / FS
    p = write_run(tmp_path, "huge", np.vstack([np.sin(2 * np.pi * 400 * t)] * 4) * 0.1)
    with h5py.File(p, "r+") as f:             # declared, never written: a few kB on disk
        data = f["entry/data"]
        for k in data:
            if isinstance(data[k], h5py.Dataset):
                data[k].resize((10**9,))
        f["entry/n_samples"][()] = 10**9
    t0 = time.perf_counter()
    assert main(["fit", str(p), "--model", "linear_stiffness", "--json"]) == 2
    err = capsys.readouterr().err
    assert str(p) in err and "1e+09" in err and err.count("\n") == 1
