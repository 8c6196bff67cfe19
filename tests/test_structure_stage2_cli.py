"""`labjoint structure stage2 STRUCTURE.toml FRF.json --law-params ... --json`."""

import json

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.structure import load_structure
from labjoint.structure.predict import FrfPredictor, synthetic_frfset

STRUCTURE = "configs/structure-seed000.toml"
TRUTH = {"richard_abbott.ke": 1e10, "richard_abbott.kp": 1e8, "richard_abbott.F_y": 3e3,
         "richard_abbott.n": 2.0}
START = ["--set", "richard_abbott.ke=1e10", "--set", "richard_abbott.kp=1e8",
         "--set", "richard_abbott.F_y=1.5e3", "--set", "richard_abbott.n=3"]


@pytest.fixture(scope="module")
def frf(tmp_path_factory):
    """Steps around modes 1 and 2 computed with a known law (F_y = 3 kN, n = 2)."""
    pr = FrfPredictor(load_structure(STRUCTURE), modes=4, harmonics=1, samples=32)
    truth = pr.law.with_params(**TRUTH)
    f = np.r_[np.linspace(36, 41, 4), np.linspace(228, 233, 2)]
    fs = synthetic_frfset(pr, truth, f, [30.0], ("free_end",), harmonics=1, noise=0.01, seed=3)
    p = tmp_path_factory.mktemp("stage2") / "sweep.json"
    fs.save(p)
    return p, truth


def test_stage2_cli_recovers_the_parameters_with_their_errors(frf, capsys):
    path, truth = frf
    assert main(["structure", "stage2", STRUCTURE, str(path), "--law-params", "F_y,n", "--modes", "4",
                 *START, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d["parameters"]) == {"richard_abbott.F_y", "richard_abbott.n"}
    for k, p in d["parameters"].items():
        assert 0 < p["stderr"] < 0.2 * abs(truth.params[k])
        assert abs(p["value"] - truth.params[k]) < 3 * p["stderr"], (k, p)
    assert d["fit_steps"] == 4 and d["validation_steps"] == 2
    assert d["error_fit_rms"] < 0.02 and d["error_validation_rms"] < 0.02   # the 1 % noise
    assert d["law"] == "richard_abbott" and d["layer"]["n"] == pytest.approx(d["parameters"]["richard_abbott.n"]["value"])


def test_stage2_cli_errors_name_the_input(frf, capsys):
    path, _ = frf
    assert main(["structure", "stage2", STRUCTURE, str(path), "--law-params", "F_S", "--json"]) != 0
    err = capsys.readouterr().err
    assert "F_S" in err and "richard_abbott.F_y" in err
    assert main(["structure", "stage2", STRUCTURE, str(path.with_name("none.json")), "--json"]) != 0
    assert "none.json" in capsys.readouterr().err
    assert main(["structure", "stage2", STRUCTURE, str(path), "--modes", "4", *START,
                 "--set", "richard_abbott.n=40", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "richard_abbott.n" in err[0] and "outside the bounds" in err[0]
