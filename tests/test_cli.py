"""The `labjoint` CLI end to end on the simulated rig, and its error contract."""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest

from labjoint.cli.main import main

ANALYZE_FIELDS = {"run", "frequency_hz", "displacement_amplitude_m", "force_amplitude_n",
                  "energy_loss_j", "damping_ns_per_m", "stiffness_n_per_m", "cycles"}


@pytest.fixture(scope="module")
def simulated_sweep(tmp_path_factory):
    """(directory, JSON output) of ``labjoint simulate --sweep 4,12,20``, made once for the
    module by whichever test asks first (so no test depends on another having run)."""
    out = tmp_path_factory.mktemp("sweep")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["simulate", "--sweep", "4,12,20", "--cycles", "20", "--sample-rate",
                   "25000", "--out", str(out), "--json"])
    lines = [ln for ln in buf.getvalue().splitlines() if ln.strip()]
    assert rc == 0 and len(lines) == 1, buf.getvalue()
    return out, json.loads(lines[0])


@pytest.fixture(scope="module")
def sweep(simulated_sweep):
    return simulated_sweep[0]


def _json(capsys):
    text = capsys.readouterr().out
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert len(lines) == 1, text  # exactly one JSON object on stdout
    return json.loads(lines[0])


def test_simulated_sweep_shows_seed002_trends(simulated_sweep):
    """Seed 002 Table 3 on the default simulated joint: across the amplitude sweep the
    energy loss rises like U^2 (the shear layer's nearly constant damping, plus a little
    micro-slip) and the stiffness softens slightly as the slip annulus grows."""
    sweep, out = simulated_sweep
    assert out["status"] == "complete"
    runs = out["runs"]
    assert [r["excitation_vpp"] for r in runs] == [4.0, 12.0, 20.0]
    U = np.array([r["displacement_amplitude_m"] for r in runs])
    W = np.array([r["energy_loss_j"] for r in runs])
    K = np.array([r["stiffness_n_per_m"] for r in runs])
    assert np.all(np.diff(U) > 0)
    assert np.all(np.diff(W) > 0)
    assert np.all(np.diff(K) < 0)
    slope = np.polyfit(np.log(U), np.log(W), 1)[0]
    assert 1.8 < slope < 2.3        # a dry contact alone gives ~3.3 (test_sim_rig)
    C = np.array([r["damping_ns_per_m"] for r in runs])
    assert C.max() / C.min() < 1.15 and 1.2e3 < C.mean() < 2.4e3   # Table 3: 1.73-1.87 kNs/m
    assert all(ANALYZE_FIELDS <= set(r) for r in runs)
    assert len(list(sweep.glob("*.h5"))) == 3


def test_analyze_json_contract(sweep, capsys):
    files = sorted(str(p) for p in sweep.glob("*.h5"))
    assert main(["analyze", *files, "--json"]) == 0
    out = _json(capsys)
    assert len(out["runs"]) == 3
    for r in out["runs"]:
        assert ANALYZE_FIELDS <= set(r)
        assert r["frequency_hz"] == pytest.approx(400.0, rel=1e-3)
        assert r["cycles"] >= 10


def test_csv_import_then_analyze_recovers_viscous_damping(tmp_path, capsys):
    """A CSV of an exact viscous joint (design.md format): C = W/(pi w U^2) returns c."""
    fs, f, c, k, U = 20000.0, 200.0, 1500.0, 8e6, 5e-6
    t = np.arange(int(fs * 0.25)) / fs
    u = U * np.sin(2 * np.pi * f * t)
    F = k * u + c * U * 2 * np.pi * f * np.cos(2 * np.pi * f * t)
    csv = tmp_path / "viscous.csv"
    with open(csv, "w") as fh:
        fh.write(f"# frequency_hz: {f}\n# torque_nm: 5\n# operator: someone\n")
        fh.write("time_s,displacement_m,force_N\n")
        np.savetxt(fh, np.column_stack([t, u, F]), delimiter=",", fmt="%.12g")
    assert main(["analyze", str(csv), "--json"]) == 0
    direct = _json(capsys)["runs"][0]
    assert direct["damping_ns_per_m"] == pytest.approx(c, rel=2e-3)
    assert direct["stiffness_n_per_m"] == pytest.approx(k, rel=2e-3)
    data = tmp_path / "data"
    assert main(["import", str(csv), "--out", str(data), "--json"]) == 0
    (h5,) = _json(capsys)["runs"]
    assert main(["analyze", h5, "--json"]) == 0
    via_file = _json(capsys)["runs"][0]
    assert via_file["energy_loss_j"] == pytest.approx(direct["energy_loss_j"], rel=1e-6)


def test_errors_are_one_line_on_stderr_with_nonzero_exit(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,displacement_mm,force_N\n0,1,2\n")
    assert main(["analyze", str(bad), "--json"]) == 2
    err = capsys.readouterr()
    assert err.out == ""
    assert "bad.csv" in err.err and "displacement_mm" in err.err
    assert len(err.err.strip().splitlines()) == 1
    assert main(["analyze", str(tmp_path / "missing.h5")]) == 2
    assert "missing.h5" in capsys.readouterr().err


def test_every_command_has_help(capsys):
    from labjoint.cli.main import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name in sub.choices:
        with pytest.raises(SystemExit) as exc:
            main([name, "--help"])
        assert exc.value.code == 0
        assert "usage: labjoint " + name in capsys.readouterr().out
