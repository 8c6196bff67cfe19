"""Shared FRF test data: seed 000's assembly with a linear joint in its file (the user's
baseline) and FRF sets computed from it with a known hidden joint law plus noise."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from labjoint.structure import structure_from_dict
from labjoint.structure.law import JointLaw
from labjoint.structure.predict import FrfPredictor, synthetic_frfset
from labjoint.tomlfile import read_toml

HIDDEN = {"iwan.K_T": 1e10, "iwan.F_S": 3e4, "iwan.chi": -0.5, "iwan.beta": 0.1, "viscous.c": 1e7}


def linear_joint_structure_dict() -> dict:
    """seed 000's assembly, both threads linear (k = 1e10 N/m), 4 patches (fast)."""
    d = read_toml("configs/structure-seed000.toml")
    for j in d["joints"]:
        j["model"] = "linear_stiffness"
        j["params"] = {"linear_stiffness.k": 1e10}
        j["stations"] = 4
        j.pop("transverse_stiffness_n_per_m", None)     # the steel layer's, as at stage 1's start
        j["layer"] = {**{k: j["layer"][k] for k in ("length_m", "thickness_m")}, "E_e_pa": 215e9}
    return d


def predictor() -> FrfPredictor:
    return FrfPredictor(structure_from_dict(linear_joint_structure_dict()), modes=4, harmonics=3,
                        samples=32)


def hidden_set(p: FrfPredictor, law: JointLaw | None, steps: int = 8, seed: int = 2):
    """Three levels (2, 5, 10 N) of steps densely around mode 1, harmonics 1-3, every sensor,
    noise 0.5 % of each step's harmonic-1 phasor plus 1e-4 m/s^2."""
    f0 = p.natural_frequencies(1)[0]
    return synthetic_frfset(p, law, np.linspace(0.96 * f0, 1.02 * f0, steps), [2.0, 5.0, 10.0], None,
                            harmonics=3, noise=0.005, floor=1e-4, seed=seed)


def hidden_law() -> JointLaw:
    return JointLaw("iwan+viscous", HIDDEN)


def write_linear_structure(path) -> None:
    """The structure of :func:`linear_joint_structure_dict` as a TOML file."""
    from pathlib import Path
    text = Path("configs/structure-seed000.toml").read_text()
    text = text.replace('model = "richard_abbott"', 'model = "linear_stiffness"')
    text = text.replace("stations = 8 ", "stations = 4 ").replace("stations = 8\n", "stations = 4\n")
    keep = []
    for line in text.splitlines():
        if line.startswith(("E_p_pa", "S_Y_pa", "n = ", "transverse_stiffness_n_per_m")):
            continue
        if line.startswith("E_e_pa"):
            line = "E_e_pa = 215e9"          # the steel layer, as at stage 1's start
        keep.append(line)
        if line.startswith("E_e_pa"):
            keep += ["[joints.params]", '"linear_stiffness.k" = 1e10']
    Path(path).write_text("\n".join(keep) + "\n")


def seed000_steel(structure=None):
    """configs/structure-seed000.toml at seed 000's stage-1 start (the file ships the updated
    joint): the layer's E_e at the steel modulus, the translational stiffness of that layer
    and Table 4's stress law (E_p = 10 MPa, S_Y = 14 MPa, n = 3.6)."""
    from labjoint.structure import load_structure
    from labjoint.structure.joint import layer_params, layer_transverse_stiffness
    from labjoint.structure.modal import with_parameter
    s = structure if structure is not None else load_structure("configs/structure-seed000.toml")
    s = with_parameter(s, "E_e_pa", 215e9)
    j = s.joints[0]
    table4 = replace(j.layer, E_p_pa=1e7, S_Y_pa=1.4e7, n=3.6)
    for k, v in layer_params(table4, j.radius_m).items():
        if k != "richard_abbott.ke":
            s = with_parameter(s, k, v)
    s = with_parameter(s, "transverse_stiffness_n_per_m", layer_transverse_stiffness(table4, j.radius_m))
    return s.with_joints(tuple(replace(jj, layer=replace(jj.layer, E_p_pa=1e7, S_Y_pa=1.4e7, n=3.6))
                               for jj in s.joints))
