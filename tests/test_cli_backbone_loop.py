"""`labjoint fit|diagnose|ladder BACKBONE.json --structure S.toml`: the comparison loop on
backbone files from the command line, alone and beside an FRF set, the backbone file
written by `labjoint backbone --out`, the model's backbone from a fit's JSON, and the
refusals (one line, exit 2). The measured backbones are mode 1 of the FRF tests'
structure with a hidden law plus stated noise (tests/backbonedata.py)."""

import json
from types import SimpleNamespace

import numpy as np
import pytest

from backbonedata import F_SD, measured, write
from frfdata import HIDDEN, hidden_law, hidden_set, predictor, write_linear_structure
from labjoint.cli.main import main
from labjoint.compare.kinds import kind_of
from labjoint.errors import InputError
from labjoint.signal.backbone import load_backbones
from labjoint.structure.law import JointLaw
from test_cli_backbone import frfset


def iwan_law():
    return JointLaw("iwan", {k: v for k, v in HIDDEN.items() if k.startswith("iwan.")})


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bbloop")
    pr = predictor()
    write_linear_structure(d / "s.toml")
    write(d / "b7.json", measured(pr, iwan_law(), n=7))
    write(d / "b2.json", measured(pr, iwan_law(), n=2))
    return d


def run(capsys, *argv):
    code = main([*map(str, argv), "--quiet"])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def test_backbone_out_writes_a_file_that_reads_back_the_same_points(tmp_path, capsys):
    fs = frfset().save(tmp_path / "set.json")
    code, out, _ = run(capsys, "backbone", fs, "--out", tmp_path / "b.json", "--json")
    assert code == 0
    first = json.loads(out)
    assert first["saved"] == str(tmp_path / "b.json")
    bs, mode = load_backbones(tmp_path / "b.json")
    assert mode == 1 and [p.method for p in bs[0].points] == ["step_sine"] * 3
    code, out, _ = run(capsys, "backbone", tmp_path / "b.json", "--json")
    again = json.loads(out)
    assert code == 0 and again["points"] == first["points"]


def test_fit_on_a_backbone_file_and_the_models_backbone_from_its_json(files, capsys, tmp_path):
    code, out, err = run(capsys, "fit", files / "b7.json", "--structure", files / "s.toml",
                         "--model", "linear_stiffness", "--modes", "4", "--json")
    assert code == 0, err
    fit = json.loads(out)
    assert fit["measurement"] == "backbone" and fit["kind"] == "backbone"
    assert fit["nrmse"] > 10 * fit["noise_floor"]        # a linear joint cannot soften
    (tmp_path / "fit.json").write_text(out)
    code, out, err = run(capsys, "backbone", "--model", tmp_path / "fit.json", "--structure",
                         files / "s.toml", "--amplitudes", "1e-5:1e-3:3", "--json")
    assert code == 0, err
    model = json.loads(out)["model"]
    f = [p["frequency_hz"] for p in model]
    b = load_backbones(files / "b7.json")[0][0]
    meas = b.array("frequency_hz")
    # linear: one frequency at every amplitude, the compromise between the measured extremes
    assert max(f) - min(f) < 1e-6 * f[0] and meas.min() < f[0] < meas.max()


@pytest.mark.parametrize("make, field", [
    (lambda d: [d / "b2.json"], "too few"),
    (lambda d: [d / "b7.json", d / "run.csv"], "cannot be judged with backbones"),
    (lambda d: [d / "bad.json"], "damping_sd"),
])
def test_refusals_are_one_line_exit_2(files, capsys, make, field):
    (files / "run.csv").write_text("time_s,displacement_m,force_N\n0,0,0\n")
    good = json.loads((files / "b7.json").read_text())
    good["backbones"][0]["points"][0]["damping_sd"] = -1.0
    (files / "bad.json").write_text(json.dumps(good))
    code, out, err = run(capsys, "diagnose", *make(files), "--structure", files / "s.toml",
                         "--model", "linear_stiffness", "--json")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and field in err, err


def test_no_structure_and_kinds_that_cannot_combine_are_refused(files, capsys):
    code, out, err = run(capsys, "fit", files / "b7.json", "--model", "linear_stiffness", "--json")
    assert code == 2 and "structure" in err and len(err.strip().splitlines()) == 1
    with pytest.raises(InputError, match="cannot be judged together"):
        kind_of([SimpleNamespace(kind="sine"), SimpleNamespace(kind="backbone")])
    assert kind_of([SimpleNamespace(kind="frf"), SimpleNamespace(kind="backbone")]).name == "frf+backbone"


@pytest.mark.slow
def test_cli_ladder_on_a_backbone_names_the_slip_law_and_reaches_the_noise(tmp_path, capsys):
    pr = predictor()
    write_linear_structure(tmp_path / "s.toml")
    write(tmp_path / "b.json", measured(pr, iwan_law(), n=12))
    code, out, err = run(capsys, "ladder", tmp_path / "b.json", "--structure", tmp_path / "s.toml",
                         "--model", "linear_stiffness", "--candidates", "viscous,iwan", "--max-steps", "2",
                         "--modes", "4", "--json")
    assert code == 0, err
    lad = json.loads(out)
    assert lad["measurement"] == "backbone"
    assert lad["steps"][0]["verdict"].startswith("add iwan")          # the hysteretic slip law
    assert [s["added"] for s in lad["steps"][1:2]] == ["iwan"]
    assert lad["steps"][-1]["nrmse_validation"] < 2 * lad["noise_floor_validation"]
    assert lad["steps"][0]["nrmse_validation"] > 20 * lad["noise_floor_validation"]
    curves = lad["steps"][1]["backbone_curves"][0]
    meas = load_backbones(tmp_path / "b.json")[0][0]
    assert curves["amplitude_m"] == pytest.approx(meas.array("amplitude"))
    assert np.abs(np.array(curves["frequency_hz"]) - meas.array("frequency_hz")).max() < 5 * F_SD
    assert lad["saved"] and all(p.endswith(".json") and ".model_ladder_" in p for p in lad["saved"])


@pytest.mark.slow
def test_cli_backbone_and_frf_set_in_one_ladder(tmp_path, capsys):
    """The hidden law iwan+viscous in both kinds of evidence: one comparison finds both."""
    pr = predictor()
    write_linear_structure(tmp_path / "s.toml")
    write(tmp_path / "b.json", measured(pr, hidden_law(), n=12))
    hidden_set(pr, hidden_law()).save(tmp_path / "frf.json")
    code, out, err = run(capsys, "ladder", tmp_path / "b.json", tmp_path / "frf.json", "--structure",
                         tmp_path / "s.toml", "--model", "linear_stiffness", "--candidates", "viscous,iwan",
                         "--max-steps", "2", "--modes", "4", "--no-save", "--json")
    assert code == 0, err
    lad = json.loads(out)
    assert lad["measurement"] == "frf+backbone"
    assert set(lad["split"].split("; ")[0:2][0].split(":")[:1]) == {"frf"} and "backbone:" in lad["split"]
    assert sorted(s["added"] for s in lad["steps"][1:]) == ["iwan", "viscous"]
    assert lad["steps"][-1]["nrmse_validation"] < 2 * lad["noise_floor_validation"]


PR_PLAN = """plan = "phase_resonance"
levels_vpp = [0.5, 1.5, 5.0]
f_start_hz = 28.0
band_hz = [20.0, 35.0]
response_channel = "free_end"
n_cycles = 60
ringdown_s = 8.0
"""


@pytest.mark.slow
def test_readme_commands_on_the_simulated_structural_rig_name_the_slip_law(tmp_path, capsys):
    """README "Backbones": the phase-resonance plan on the simulated structural rig (its
    threads a hidden continuous Iwan law, integrated in time, read through the driver code
    path), its backbone file, a diagnosis of a linear joint inside the seed-000 structure
    file (the linear joint fails in damping at large amplitude and the slip law is named)
    and the ladder with the linear damping measured from the backbones."""
    (tmp_path / "pr.toml").write_text(PR_PLAN)
    code, _, err = run(capsys, "simulate", "--config", "configs/rig-structure-sim.toml", "--plan",
                       tmp_path / "pr.toml", "--out", tmp_path / "data")
    assert code == 0, err
    runs = sorted((tmp_path / "data").glob("*.h5"))
    assert len(runs) == 4 and any("ringdown" in p.name for p in runs)
    # the other modes' residual compliance between drive and free end at mode 1, from the
    # structure file (1.25e-7 m/N): with it the ringdown's force removal takes the
    # half-octave band by default
    code, out, err = run(capsys, "backbone", *runs, "--out", tmp_path / "pr.json", "--residual-compliance",
                         "configs/structure-seed000.toml", "--json")
    assert code == 0, err
    assert any("order 4" in n for n in json.loads(out)["notes"])
    assert any("residual compliance 1.247e-07 m/N" in n for n in json.loads(out)["notes"])
    methods = {p["method"] for p in json.loads(out)["points"]}
    assert methods == {"phase_resonance", "ringdown_hilbert", "ringdown_peaks"}
    code, out, err = run(capsys, "diagnose", tmp_path / "pr.json", "--structure", "configs/structure-seed000.toml",
                         "--model", "linear_stiffness", "--candidates", "viscous,iwan", "--json")
    assert code == 0, err
    dg = json.loads(out)
    assert dg["measurement"] == "backbone" and dg["verdict"].startswith("add iwan"), dg["verdict"]
    top = [f["text"] for f in dg["failures"] if "phase_resonance/even damping_ratio" in f["where"]]
    assert top and top[0].startswith("damping too low above")
    best = dg["candidates"][0]
    # the structure file's linear damping (0.5 %, the rig's 0.42 %) left in: 0.19x
    assert best["effect"] == "iwan" and best["significant"]
    assert best["nrmse_after_validation"] < 0.3 * dg["nrmse_validation"]
    code, out, err = run(capsys, "ladder", tmp_path / "pr.json", "--structure", "configs/structure-seed000.toml",
                         "--model", "linear_stiffness", "--candidates", "viscous,iwan", "--max-steps", "2",
                         "--linear-damping", "measured", "--no-save", "--json")
    assert code == 0, err
    lad = json.loads(out)
    assert [s["added"] for s in lad["steps"][1:2]] == ["iwan"]
    floor = lad["noise_floor_validation"]
    assert lad["steps"][0]["nrmse_validation"] > 100 * floor
    # the linear damping extrapolated to zero amplitude (the continuous Iwan's damping
    # rises from the lowest amplitudes): 0.418 % where the structure's is 0.420 %
    assert "extrapolated to zero amplitude" in lad["linear_damping"]
    # near the noise: 1.8x on this run with the residual compliance and the half-octave
    # band and the ringdown windows' sds at least their scatter about their neighbours
    # (3.9x without the two force-removal options, 5.2x before the scatter; 61-279x against
    # 24 discrete sliders; see README)
    assert lad["steps"][-1]["nrmse_validation"] < 3 * floor


def test_model_json_shapes_a_backbone_model_takes(tmp_path, capsys):
    """--model MODEL.json: a saved model file, a fit's JSON, a ladder's (its last step);
    anything else is refused naming the file."""
    from labjoint.cli.cmd_backbone import model_file

    params = {"linear_stiffness.k": {"value": 2e8, "stderr": None, "unit": "N/m"}}
    shapes = {"saved.json": {"format": "labjoint-model/1", "model": "linear_stiffness", "parameters": params},
              "fit.json": {"model": "linear_stiffness", "nrmse": 0.1, "parameters": params},
              "ladder.json": {"steps": [{"model": "viscous", "parameters": {}},
                                        {"model": "linear_stiffness", "parameters": params}]}}
    for name, d in shapes.items():
        (tmp_path / name).write_text(json.dumps(d))
        assert model_file(str(tmp_path / name)) == ("linear_stiffness", {"linear_stiffness.k": 2e8})
    (tmp_path / "runs.json").write_text(json.dumps({"runs": []}))
    code, out, err = run(capsys, "backbone", "--model", tmp_path / "runs.json", "--mass", "1",
                         "--amplitudes", "1e-6:1e-3:3", "--json")
    assert code == 2 and out == "" and "runs.json" in err and len(err.strip().splitlines()) == 1
