"""Beam elements and modal analysis against closed forms; stage-1 updating (seed 000)."""

from pathlib import Path

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.structure import load_structure, modes, structure_from_dict, update_stiffness

ROOT = Path(__file__).resolve().parent.parent
SEED000 = ROOT / "configs" / "structure-seed000.toml"
E, RHO, NU = 210e9, 7850.0, 0.3
BETA_L = np.array([1.8751040687, 4.6940911330, 7.8547574382])   # cantilever roots


def beam(length, od, wall, theory, support="clamped", el=0.02, extra_support=None):
    d = {"structure": {"beam": theory, "element_length_m": el},
         "materials": {"s": {"E_pa": E, "rho_kg_m3": RHO, "nu": NU}},
         "sections": {"p": {"od_m": od, "wall_m": wall}},
         "components": {"b": {"section": "p", "material": "s", "length_m": length}},
         "supports": [{"component": "b", "x_m": 0.0, "type": support}],
         "excitation": {"component": "b", "x_m": length},
         "sensors": [{"name": "tip", "component": "b", "x_m": length}]}
    if extra_support:
        d["supports"].append({"component": "b", "x_m": length, "type": extra_support})
        d["excitation"]["x_m"] = length / 2
        d["sensors"][0]["x_m"] = length / 2
    return structure_from_dict(d)


def test_euler_bernoulli_cantilever_matches_closed_form():
    s = beam(1.5, 0.114, 0.0038, "euler_bernoulli")
    sec = s.components[0].section
    f = BETA_L ** 2 / (2 * np.pi * 1.5 ** 2) * np.sqrt(E * sec.inertia_m4 / (RHO * sec.area_m2))
    assert modes(s, 3).frequencies_hz == pytest.approx(f, rel=1e-6)


def _timoshenko_ss(n, length, sec):
    """Simply supported Timoshenko beam: the smaller root of the dispersion relation."""
    k = n * np.pi / length
    A, I, G = sec.area_m2, sec.inertia_m4, E / (2 * (1 + NU))
    kap = sec.shear_coefficient(NU)
    a = RHO ** 2 * I / (kap * G)
    b = -(RHO * A + RHO * I * k * k * (1 + E / (kap * G)))
    c = E * I * k ** 4
    w2 = (-b - np.sqrt(b * b - 4 * a * c)) / (2 * a)
    return np.sqrt(w2) / (2 * np.pi)


def test_timoshenko_converges_to_exact_simply_supported_frequencies():
    length = 0.6                                     # stubby: shear and rotary inertia matter
    errors = []
    for el in (0.05, 0.025, 0.0125):
        s = beam(length, 0.114, 0.0038, "timoshenko", support="pinned", el=el, extra_support="pinned")
        exact = np.array([_timoshenko_ss(n, length, s.components[0].section) for n in (1, 2, 3)])
        errors.append(np.abs(modes(s, 3).frequencies_hz / exact - 1))
    errors = np.array(errors)
    assert errors[-1].max() < 1.5e-3
    assert np.all(errors[1:] < errors[:-1] / 3.5)                 # second order in element size
    eb = beam(length, 0.114, 0.0038, "euler_bernoulli", support="pinned", el=0.0125, extra_support="pinned")
    assert modes(eb, 1).frequencies_hz[0] > 1.02 * modes(s, 1).frequencies_hz[0]   # shear softens


def test_seed000_stage1_update_lowers_both_modes_towards_table3():
    from frfdata import seed000_steel
    s = seed000_steel(load_structure(SEED000))
    r = update_stiffness(s, [28.5, 177.0])
    assert r.initial_hz[0] > 35 and r.initial_hz[1] > 210          # a stiff joint: too high
    assert abs(r.updated_hz[0] / 28.5 - 1) < 0.03 and abs(r.updated_hz[1] / 177.0 - 1) < 0.04
    assert r.bounds == (pytest.approx(215e9 * 1e-5), pytest.approx(215e9 * 1.1))
    assert r.history[-1]["objective"] < r.history[0]["objective"] / 100
    # at the optimum the Eq. 7 objective is stationary in log E_e
    from labjoint.structure.modal import with_parameter
    obj = [np.sum((modes(with_parameter(s, "E_e_pa", r.value * f), 2).frequencies_hz / [28.5, 177] - 1) ** 2)
           for f in (0.98, 1.0, 1.02)]
    assert obj[1] <= min(obj[0], obj[2])


def test_update_recovers_a_known_stiffness():
    from frfdata import seed000_steel
    from labjoint.structure.modal import with_parameter
    s = seed000_steel(load_structure(SEED000))
    truth = with_parameter(s, "E_e_pa", 5e8)
    r = update_stiffness(s, modes(truth, 2).frequencies_hz)
    assert r.value == pytest.approx(5e8, rel=1e-4)


@pytest.mark.parametrize("edit, field", [
    (lambda d: d["components"]["coupling"].pop("section"), "components.coupling.section"),
    (lambda d: d["sections"]["pipe"].update(wall_m=0.0), "sections.pipe.wall_m"),
    (lambda d: d["joints"][0].update(model="iwan+nonsense"), "joints.thread_short.model"),
    (lambda d: d["sensors"][2].update(x_m=3.0), "sensors.free_end.x_m"),
    (lambda d: d["joints"].pop(1), "components.long_pipe"),
    (lambda d: d["joints"][0]["layer"].pop("S_Y_pa"), "joints.thread_short.layer.S_Y_pa"),
    (lambda d: d["supports"][0].update(type="glued"), "supports[0].type"),
])
def test_bad_structure_files_name_the_key(edit, field):
    import tomllib
    d = tomllib.loads(SEED000.read_text())
    edit(d)
    with pytest.raises(InputError) as exc:
        structure_from_dict(d)
    assert exc.value.field == field
