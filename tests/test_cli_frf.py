"""`labjoint fit|diagnose|ladder FRF.json --structure STRUCTURE.toml` (the frf kind on the CLI)."""

import json
from pathlib import Path

import pytest

from frfdata import hidden_law, hidden_set, predictor, write_linear_structure
from labjoint.cli.main import main


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("frf")
    hidden_set(predictor(), hidden_law(), steps=5).save(d / "sweep.json")
    write_linear_structure(d / "lin.toml")
    return d


def _json(capsys, argv):
    code = main(argv)
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out)


def test_ladder_on_an_frf_file_saved_beside_it(files, capsys):
    before = (files / "sweep.json").read_bytes()
    res = _json(capsys, ["ladder", str(files / "sweep.json"), "--model", "linear_stiffness",
                         "--structure", str(files / "lin.toml"), "--modes", "4",
                         "--candidates", "viscous", "--max-steps", "1", "--json"])
    assert res["measurement"] == "frf"
    assert [s["model"] for s in res["steps"]] == ["linear_stiffness", "linear_stiffness+viscous"]
    assert res["steps"][1]["nrmse_validation"] < 0.5 * res["steps"][0]["nrmse_validation"]
    (saved,) = res["saved"]
    assert saved.startswith(str(files / "sweep.model_ladder_"))
    assert json.loads(Path(saved).read_text())["steps"][1]["added"] == "viscous"
    assert (files / "sweep.json").read_bytes() == before          # the FRF file is not rewritten


def test_diagnose_json_names_where_it_fails(files, capsys):
    res = _json(capsys, ["diagnose", str(files / "sweep.json"), "--model", "linear_stiffness",
                         "--structure", str(files / "lin.toml"), "--modes", "4", "--harmonics", "2",
                         "--candidates", "cubic_stiffness", "--json"])
    assert res["measurement"] == "frf" and res["kind"] == "frf"
    assert not res["adequate"] and res["nrmse"] > 3 * res["noise_floor"]
    assert res["failures"][0]["text"].startswith("mode 1,")
    assert [c["effect"] for c in res["candidates"]] == ["cubic_stiffness"]


def test_bad_input_names_the_option(files, capsys):
    assert main(["fit", str(files / "sweep.json"), "--model", "linear_stiffness", "--json"]) != 0
    assert "structure" in capsys.readouterr().err
    assert main(["fit", str(files / "sweep.json"), "--model", "linear_stiffness", "--structure",
                 str(files / "nowhere.toml"), "--json"]) != 0
    assert "nowhere.toml" in capsys.readouterr().err
    assert main(["fit", str(files / "sweep.json"), "--model", "coulomb+wear", "--structure",
                 str(files / "lin.toml"), "--modes", "4", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "wear" in err[0] and "steady periodic" in err[0]


def test_too_few_steps_near_a_resonance_is_refused(files, capsys):
    hidden_set(predictor(), None, steps=2).save(files / "two.json")
    assert main(["diagnose", str(files / "two.json"), "--model", "linear_stiffness", "--structure",
                 str(files / "lin.toml"), "--modes", "4", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "too few near a resonance" in err[0] and "at least 3 steps" in err[0]
