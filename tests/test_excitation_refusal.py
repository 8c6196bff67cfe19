"""Sine-only pipelines refuse a record that is not a steady sine, naming what it is."""

import json

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.identify.analyze import analyze_run
from labjoint.storage import import_csv
from labjoint.storage.csv_parse import parse_csv

FS = 750.0


def _multisine_csv(tmp_path, periods=3, n=4096, seed=2):
    """A multisine force (5-150 Hz) through a 2 kg / 5e4 N/m / 10 Ns/m oscillator, as
    the import format with no frequency metadata (the Bouc-Wen benchmark's shape)."""
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, 1 / FS)
    sel = (f >= 5) & (f <= 150)
    spec = np.zeros(f.size, complex)
    spec[sel] = 50 * np.sqrt(2 * n) * np.exp(2j * np.pi * rng.random(sel.sum())) / np.sqrt(sel.sum())
    force = np.tile(np.fft.irfft(spec, n), periods)
    w = 2 * np.pi * f
    h = 1.0 / (5e4 - 2.0 * w ** 2 + 10j * w)               # steady-state FRF of the SDOF
    disp = np.tile(np.fft.irfft(spec * h, n), periods)
    t = np.arange(force.size) / FS
    p = tmp_path / "multisine.csv"
    rows = "\n".join(f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), disp.tolist(), force.tolist()))
    p.write_text("time_s,displacement_m,force_N\n" + rows + "\n")
    return p


def test_analyze_run_refuses_a_multisine(tmp_path):
    run = parse_csv(_multisine_csv(tmp_path)).to_run()
    with pytest.raises(InputError, match=r"multisine with period 5.46\d* s .*not a steady sine"):
        analyze_run(run, frequency_hz=41.0)


def test_analyze_refuses_a_multisine_and_names_the_commands_that_handle_it(tmp_path, capsys):
    csv = _multisine_csv(tmp_path)
    data = tmp_path / "data"
    data.mkdir()
    h5 = import_csv(csv, data)
    for path in (str(csv), str(h5)):
        code = main(["analyze", path, "--json"])
        err = capsys.readouterr()
        assert code == 2, err
        assert err.out == ""
        assert "multisine" in err.err and "labjoint fit" in err.err and "labjoint diagnose" in err.err


def test_fit_and_diagnose_judge_a_multisine_along_the_record_and_find_the_missing_mass(tmp_path, capsys):
    """The record is F = m a + c v + k u (2 kg, 10 Ns/m, 5e4 N/m): fitting stiffness and
    damping only leaves the mass's force, which diagnose names; the fit with inertia
    recovers all three."""
    csv = _multisine_csv(tmp_path, periods=6)
    assert main(["diagnose", str(csv), "--model", "linear_stiffness+viscous",
                 "--candidates", "inertia,cubic_stiffness,offset", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["kind"] == "record" and not res["adequate"]
    assert res["verdict"].startswith("add inertia"), res["verdict"]
    assert main(["fit", str(csv), "--model", "inertia+viscous+linear_stiffness", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    p = {k: v["value"] for k, v in res["parameters"].items()}
    assert p["inertia.m"] == pytest.approx(2.0, rel=0.01)
    assert p["linear_stiffness.k"] == pytest.approx(5e4, rel=0.01)
    assert p["viscous.c"] == pytest.approx(10.0, rel=0.1)
    assert res["nrmse"] < 0.01


def test_a_joint_force_fading_under_a_steady_drive_is_still_a_sine():
    """Wear: the joint force falls to a tenth while the drive holds; the excitation is
    read from the reference force, so the run is analysed, not called a transient."""
    from labjoint.storage.run import Run
    fs, f = 25_600.0, 400.0
    t = np.arange(int(0.25 * fs)) / fs
    fade = 0.1 + 0.9 * np.exp(-t / 0.05)
    u = 1e-6 * np.sin(2 * np.pi * f * t)
    joint = 100.0 * fade * np.sin(2 * np.pi * f * t + 0.2)
    ref = 50.0 * np.sin(2 * np.pi * f * t)
    run = Run("wear", t, u, joint, {"frequency_hz": f, "sample_rate_hz": fs},
              {"force_ref": ref, "shear_nc": joint})
    with pytest.raises(InputError, match="transient"):
        analyze_run(Run("no_ref", t, u, joint, {"frequency_hz": f, "sample_rate_hz": fs}))
    result = analyze_run(run, cutoff_hz=None)
    assert result.n_cycles >= 50
