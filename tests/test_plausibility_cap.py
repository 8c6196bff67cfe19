"""The displacement cap (issue 29 item 6): a config value with a CLI override, checked on
the samples before the loop pipeline and the fit."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from labjoint.compare.kinds import prepare
from labjoint.errors import InputError
from labjoint.identify.plausible import Plausibility

LABJOINT = [sys.executable, "-m", "labjoint.cli.main"]


def _csv(path, amp=0.02, f=10.0, fs=2000.0, k=1e3, c=2.0):
    t = np.arange(int(4 * fs)) / fs
    u = amp * np.sin(2 * np.pi * f * t)
    F = k * u + c * amp * 2 * np.pi * f * np.cos(2 * np.pi * f * t)
    rows = "\n".join(f"{a:.6f},{b:.9e},{x:.9e}" for a, b, x in zip(t, u, F))
    path.write_text(f"# frequency_hz: {f}\n# sample_rate_hz: {fs}\ntime_s,displacement_m,force_N\n{rows}\n")
    return path


def test_cap_refuses_before_the_pipeline_and_the_override_takes_it(tmp_path):
    p = _csv(tmp_path / "tip.csv")
    with pytest.raises(InputError, match=r"run 'tip': amplitude 0\.02 m .*above 0\.01 m.*--max-displacement") as e:
        prepare([p], kind="sine")
    assert e.value.field == "displacement"
    (m,) = prepare([p], kind="sine", plausibility=Plausibility(max_displacement_amplitude_m=0.05))
    assert m.loop.summary["displacement_amplitude_m"] == pytest.approx(0.02, rel=1e-3)
    with pytest.raises(InputError, match="above 0.015 m"):
        prepare([p], kind="sine", plausibility=Plausibility(max_displacement_amplitude_m=0.015))


def test_cli_flag_and_config(tmp_path):
    p = _csv(tmp_path / "tip.csv")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    r = subprocess.run([*LABJOINT, "fit", str(p), "--model", "linear_stiffness+viscous", "--json"],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 2 and r.stdout == ""
    assert "--max-displacement" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    r = subprocess.run([*LABJOINT, "fit", str(p), "--model", "linear_stiffness+viscous", "--json",
                        "--max-displacement", "0.05"], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    k = json.loads(r.stdout)["parameters"]["linear_stiffness.k"]["value"]
    assert k == pytest.approx(1e3, rel=1e-3)
    from labjoint.config import DEFAULT_CONFIG
    cfg = tmp_path / "rig.toml"
    cfg.write_text(DEFAULT_CONFIG.read_text() + "\n[plausibility]\nmax_displacement_amplitude_m = 0.05\n")
    r = subprocess.run([*LABJOINT, "fit", str(p), "--model", "linear_stiffness+viscous", "--json",
                        "--config", str(cfg)], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([*LABJOINT, "analyze", str(p), "--json", "--max-displacement", "0.05"],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["runs"][0]["displacement_amplitude_m"] == pytest.approx(0.02, rel=1e-3)


def test_other_limits_are_config_values_too(tmp_path):
    """min_samples_per_period and the frequency mismatch move by the [plausibility] table;
    unknown or non-positive limits are refused by name."""
    from labjoint.identify.analyze import analyze_run
    from labjoint.storage.reader import read_any

    run = read_any(_csv(tmp_path / "coarse.csv", amp=2e-5, f=250.0, fs=2000.0))    # 8 samples per period
    with pytest.raises(InputError, match="at least 10"):
        analyze_run(run, cutoff_hz=None)
    res = analyze_run(run, cutoff_hz=None, plausibility=Plausibility(min_samples_per_period=6.0))
    assert res.summary["displacement_amplitude_m"] == pytest.approx(2e-5, rel=0.01)
    with pytest.raises(InputError) as e:
        Plausibility.from_mapping({"max_displacement": 1.0})
    assert e.value.field == "plausibility.max_displacement"
    with pytest.raises(InputError) as e:
        Plausibility(max_frequency_mismatch=0.0)
    assert e.value.field == "plausibility.max_frequency_mismatch"
