"""`labjoint analyze`: --force and --save do what --help says for every method, and the
stick-slip columns say they are model values (issue 12 item 3)."""

import json

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.storage import open_run
from test_stickslip_simrig import MU_SIM, SEED_LIKE_JOINT, write_sim_run


@pytest.fixture(scope="module")
def run_path(tmp_path_factory):
    d = tmp_path_factory.mktemp("flags")
    return str(write_sim_run(d, "ref", 400.0, 20.0, 5.0, seconds=0.1, sim=SEED_LIKE_JOINT))


def _rows(capsys, argv):
    assert main(["analyze", *argv, "--friction", str(MU_SIM), "--json"]) == 0
    return json.loads(capsys.readouterr().out)["runs"]


@pytest.mark.parametrize("method", ["loop", "stickslip", "both"])
def test_force_flag_is_used_by_every_method(run_path, capsys, method):
    joint = _rows(capsys, [run_path, "--method", method])[0]
    ref = _rows(capsys, [run_path, "--method", method, "--force", "reference"])[0]
    # the reference sensor also carries beam 1's inertia: a different force, other numbers
    key = "stiffness_n_per_m" if method != "stickslip" else "stickslip_stiffness_n_per_m"
    assert joint[key] != pytest.approx(ref[key], rel=1e-3)
    if method != "loop":
        assert ref["force_sensor"] == "reference" and joint["force_sensor"] == "joint"


def test_save_with_both_writes_both_results(tmp_path, capsys):
    path = str(write_sim_run(tmp_path, "save", 400.0, 12.0, 5.0, seconds=0.1, sim=SEED_LIKE_JOINT))
    (row,) = _rows(capsys, [path, "--method", "both", "--save"])
    with open_run(path) as rf:
        assert {"loop", "stickslip"} <= set(rf.processed_names)
        loop, attrs = rf.processed("loop")
    assert attrs["energy_loss_j"] == pytest.approx(row["energy_loss_j"])
    assert attrs["basis"].startswith("measured")


def test_stickslip_columns_are_labelled_model_based(run_path, capsys):
    (row,) = _rows(capsys, [run_path, "--method", "both"])
    assert row["stickslip_basis"].startswith("model-based")
    assert row["loop_basis"].startswith("measured")
    # the model's C is the loop stiffness over pi omega, exactly (not a second measurement)
    k = row["stickslip_stiffness_n_per_m"]
    assert row["stickslip_damping_ns_per_m"] == pytest.approx(k / (np.pi * 2 * np.pi * 400.0),
                                                              rel=2e-3)
    assert main(["analyze", run_path, "--method", "both", "--friction", str(MU_SIM)]) == 0
    text = capsys.readouterr().out
    assert "W model mJ" in text and "C model Ns/m" in text
    assert "not an independent check" in text


@pytest.mark.parametrize("mu", ["1e-300", "0", "80"])
def test_a_friction_coefficient_no_contact_has_is_one_clear_error(run_path, capsys, mu):
    # 1e-300 overflowed the loads K_t u / (mu N) of Eq. 6 (a RuntimeWarning, then nonsense)
    assert main(["analyze", run_path, "--method", "stickslip", "--friction", mu]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "friction coefficient must be between" in err[0]
