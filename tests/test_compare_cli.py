"""`labjoint fit|diagnose|ladder RUN... --model EXPR [--json]`: the CLI contract."""

import json

import pytest

from labjoint.cli.main import main
from labjoint.storage import import_csv
from test_compare_synth import sweep, write_csv


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    csvs, h5 = [], []
    for r in sweep(freqs=(200.0, 400.0), amps=(3e-6, 8e-6), k=1e7, c=120.0, cycles=12):
        p = d / f"{r.name}.csv"
        write_csv(p, r)
        csvs.append(str(p))
        h5.append(str(import_csv(p, d / "data")))
    return csvs, h5


def _json(capsys, argv):
    code = main(argv)
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out)


def test_fit_json_contract_on_csv_files(files, capsys):
    res = _json(capsys, ["fit", *files[0], "--model", "linear_stiffness+viscous", "--json", "--quiet"])
    assert res["model"] == "linear_stiffness+viscous"
    c = res["parameters"]["viscous.c"]
    assert set(c) == {"value", "stderr", "unit"} and c["unit"] == "N s/m"
    assert c["value"] == pytest.approx(120.0, rel=0.03)
    assert res["nrmse"] <= 1.5 * res["noise_floor"]
    assert len(res["runs"]) == 4
    assert set(res["runs"][0]) >= {"run", "nrmse", "energy_loss_error_pct", "stiffness_error_pct"}


def test_diagnose_json_contract_on_run_files(files, capsys):
    res = _json(capsys, ["diagnose", *files[1], "--model", "linear_stiffness", "--json", "--quiet",
                         "--candidates", "viscous,offset", "--jobs", "1"])
    assert set(res) >= {"model", "nrmse", "noise_floor", "adequate", "failures", "candidates"}
    assert res["candidates"][0]["effect"] == "viscous" and res["candidates"][0]["significant"]
    assert not res["adequate"]


def test_ladder_json_contract(files, capsys):
    res = _json(capsys, ["ladder", *files[1], "--model", "linear_stiffness", "--json", "--quiet",
                         "--candidates", "viscous,offset", "--jobs", "1", "--max-steps", "2",
                         "--no-save"])
    assert set(res) >= {"steps", "noise_floor", "adequate"}
    assert [s["added"] for s in res["steps"]] == [None, "viscous"]
    assert res["adequate"]


def test_tables_without_json(files, capsys):
    assert main(["fit", *files[1], "--model", "linear_stiffness+viscous", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "viscous.c" in out and "noise floor" in out
    assert main(["diagnose", *files[1], "--model", "linear_stiffness", "--quiet",
                 "--candidates", "viscous", "--jobs", "1"]) == 0
    out = capsys.readouterr().out
    assert "where it fails" in out and "viscous" in out


def test_bad_model_is_an_input_error_with_exit_code_2(files, capsys):
    code = main(["fit", files[0][0], "--model", "linear_stiffness+viscus", "--json"])
    out = capsys.readouterr()
    assert code == 2 and out.out == "" and "viscus" in out.err


def test_missing_file_names_it(tmp_path, capsys):
    code = main(["fit", str(tmp_path / "nope.h5"), "--model", "linear_stiffness", "--json"])
    out = capsys.readouterr()
    assert code == 2 and "nope.h5" in out.err
