"""`labjoint structure measured` and `labjoint structure ema` on step-sine runs of the
simulated structural rig."""

import json

import numpy as np
import pytest

from labjoint.acquisition.plans import step_sine
from labjoint.cli.main import main
from labjoint.signal.frfset import FrfSet
from structure_runs import run_plans


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("runs")
    freqs = [float(x) for x in np.arange(27.25, 29.76, 0.25)]
    (r,) = run_plans(d, [(step_sine(freqs, 2.0, n_cycles=16, measure_cycles=8,
                                    directions=["up"]), "cli")])
    assert r.status == "complete"
    return sorted(d.glob("*.h5"))


def test_measured_then_ema(runs, tmp_path, capsys):
    out = tmp_path / "frf.json"
    assert main(["structure", "measured", *map(str, runs), "--out", str(out), "--harmonics", "2",
                 "--segments", "4", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["steps"] == len(runs) and res["drive_voltage"] is True and res["harmonics"] == 2
    assert res["groups"] == [{"level_n": 2.0, "direction": "up", "steps": len(runs),
                              "frequencies_hz": [27.25, 29.75]}]
    s = FrfSet.load(out)
    assert np.abs(s.force) == pytest.approx(2.0, rel=0.06)
    assert main(["structure", "ema", str(out), "--json"]) == 0
    (g,) = json.loads(capsys.readouterr().out)["groups"]
    assert g["lscf"]["natural_frequency_hz"] == pytest.approx(28.5, abs=0.3)
    assert g["half_power"]["natural_frequency_hz"] == pytest.approx(g["lscf"]["natural_frequency_hz"], abs=0.2)


def test_errors_name_the_input(runs, tmp_path, capsys):
    assert main(["structure", "measured", str(runs[0]), "--out", str(tmp_path / "x.json"),
                 "--sensors", "tip", "--json"]) != 0
    assert "tip" in capsys.readouterr().err
    assert main(["structure", "ema", str(tmp_path / "missing.json"), "--json"]) != 0
    assert "missing.json" in capsys.readouterr().err
