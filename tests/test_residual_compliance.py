"""The other modes' residual compliance from a structure file (issue 30,
labjoint.structure.residual): a 2-DOF spring chain against its closed form, seed 000's
structure file, and `labjoint backbone --residual-compliance S.toml`'s refusals."""

import math

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.structure import load_structure
from labjoint.structure.assembly import Structure
from labjoint.structure.residual import residual_compliance

K, M = 2.0e6, 1.5


def chain() -> Structure:
    """ground -k- m1 -k- m2, drive at m2, sensors at m1 and m2 (no joints)."""
    Kc = K * np.array([[2.0, -1.0], [-1.0, 1.0]])
    return Structure(name="chain", theory="springs", components=(), node_x=np.array([0.0, 1.0]),
                     node_component=np.zeros(2, int), dof_index=np.array([0, -1, 1, -1]),
                     M=M * np.eye(2), K0=Kc, joints=(), force=np.array([0.0, 1.0]),
                     sensor_names=("m1", "m2"), sensors=np.eye(2))


def test_two_dof_chain_closed_form():
    # eigenvalues (3 -+ sqrt5)/2 k/m, shapes (1, phi) and (1, -1/phi), phi the golden ratio:
    # G = K^-1 = [[1, 1], [1, 2]] / k; mode 1 removed leaves mode 2's share
    # phi_2,s phi_2,d / w_2^2 = v_s v_d / (|v|^2 lambda_2 k), |v|^2 lambda_2 = 5 + 2 sqrt5
    # (drive point: (1/phi^2)/..., transfer: (-1/phi)/...); mode 2 removed leaves mode 1's
    golden = (1 + math.sqrt(5)) / 2
    s = chain()
    assert residual_compliance(s, "m2", 1) == pytest.approx(1 / ((5 + 2 * math.sqrt(5)) * K), rel=1e-12)
    assert residual_compliance(s, "m1", 1) == pytest.approx(-golden / ((5 + 2 * math.sqrt(5)) * K), rel=1e-12)
    assert residual_compliance(s, "m2", 2) == pytest.approx(1 / ((5 - 2 * math.sqrt(5)) * K), rel=1e-12)
    # the two modes' shares add up to the static flexibility 2/k
    assert residual_compliance(s, "m2", 1) + residual_compliance(s, "m2", 2) == pytest.approx(2 / K, rel=1e-12)


def test_refusals_name_the_sensor_and_mode():
    with pytest.raises(InputError, match="no sensor 'tip'") as e:
        residual_compliance(chain(), "tip", 1, file="s.toml")
    assert e.value.file == "s.toml" and e.value.field == "sensor"
    with pytest.raises(InputError, match="mode 3"):
        residual_compliance(chain(), "m2", 3)


def test_seed000_structure_file():
    # 1.247e-7 m/N at the free end (the simulator's FE, Euler-Bernoulli with rigid thread
    # ties, gave 1.06e-7: README "Backbones")
    s = load_structure("configs/structure-seed000.toml")
    assert residual_compliance(s, "free_end", 1) == pytest.approx(1.247e-7, rel=2e-3)


def test_cli_refuses_a_bad_file_or_sensor_in_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[structure\n")
    for argv, word in (([str(tmp_path / "none.toml"), "--sensor", "free_end"], "none.toml"),
                       ([str(bad), "--sensor", "free_end"], "bad.toml"),
                       (["configs/structure-seed000.toml", "--sensor", "tip"], "tip"),
                       (["1e-7x"], "1e-7x")):
        code = main(["backbone", "--residual-compliance", *argv, "--mass", "1", "--model", "linear_stiffness",
                     "--param", "linear_stiffness.k=1e4", "--amplitudes", "1e-4:1e-3:3", "--quiet"])
        err = capsys.readouterr().err
        assert code == 2 and word in err and err.count("\n") == 1, err
