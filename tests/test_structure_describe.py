"""Structures a user can describe (issue 29 item 4): rectangular and general sections, the
bolted lap joint, the shaker's moving mass, and stage 1 refusing what is no answer.
Checked against closed forms (Euler-Bernoulli cantilever, a lap-jointed cantilever's static
tip deflection) and an independent beam model written here."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.structure.config import structure_from_dict
from labjoint.structure.modal import modes, update_stiffness, with_parameter

ROOT = Path(__file__).resolve().parent.parent
BERT = ROOT / "configs" / "structure-bert.toml"
E, RHO, B, H = 70e9, 2700.0, 0.0254, 0.00635
I, A = B * H ** 3 / 12, B * H
BETA_L = np.array([1.8751040687, 4.6940911330, 7.8547574382])      # cantilever roots


def _beam(components: dict, joints: list, tip: tuple[str, float], section: dict | None = None,
          el: float = 0.01, theory: str = "euler_bernoulli", moving: float = 0.0) -> dict:
    return {"structure": {"beam": theory, "element_length_m": el},
            "materials": {"al": {"E_pa": E, "rho_kg_m3": RHO, "nu": 0.33}},
            "sections": {"bar": section or {"b_m": B, "h_m": H}},
            "components": {k: {"section": "bar", "material": "al", "x_start_m": x0, "length_m": ln}
                           for k, (x0, ln) in components.items()},
            "supports": [{"component": next(iter(components)), "x_m": 0.0, "type": "clamped"}],
            "joints": joints,
            "excitation": {"component": tip[0], "x_m": tip[1], "moving_mass_kg": moving},
            "sensors": [{"name": "tip", "component": tip[0], "x_m": tip[1]}]}


def _lap(k: float, kt: float, overlap: float, l1: float = 0.27, l2: float = 0.27, stations: int = 8,
         contact: float | None = None, model: str = "linear_stiffness", extra: dict | None = None) -> dict:
    j = {"name": "lap", "type": "lap", "between": ["a", "b"], "transverse_stiffness_n_per_m": kt,
         "stations": stations, "model": model, "params": {"linear_stiffness.k": k, **(extra or {})}}
    if contact is not None:
        j["contact_length_m"] = contact
    return _beam({"a": (0.0, l1), "b": (l1 - overlap, l2)}, [j], ("b", l1 + l2 - overlap))


def test_rectangular_cantilever_matches_euler_bernoulli():
    L = 0.5
    s = structure_from_dict(_beam({"a": (0.0, L)}, [], ("a", L), el=0.005))
    exact = BETA_L ** 2 / (2 * np.pi * L ** 2) * np.sqrt(E * I / (RHO * A))
    assert modes(s, 3).frequencies_hz == pytest.approx(exact, rel=2e-5)
    # pinned at both ends: (n pi)^2 / (2 pi L^2) sqrt(EI / rho A)
    d = _beam({"a": (0.0, L)}, [], ("a", L / 3), el=0.005)
    d["supports"] = [{"component": "a", "x_m": 0.0, "type": "pinned"}, {"component": "a", "x_m": L, "type": "pinned"}]
    ss = (np.arange(1, 4) * np.pi) ** 2 / (2 * np.pi * L ** 2) * np.sqrt(E * I / (RHO * A))
    assert modes(structure_from_dict(d), 3).frequencies_hz == pytest.approx(ss, rel=2e-5)
    # a general section with the rectangle's A and I (and shear coefficient) is the same beam
    kappa = 10 * 1.33 / (12 + 11 * 0.33)
    g = structure_from_dict(_beam({"a": (0.0, L)}, [], ("a", L), theory="timoshenko", section={
        "area_m2": A, "inertia_m4": I, "torsion_m4": 1e-9, "shear_coefficient": kappa}))
    r = structure_from_dict(_beam({"a": (0.0, L)}, [], ("a", L), theory="timoshenko"))
    assert modes(g, 3).frequencies_hz == pytest.approx(modes(r, 3).frequencies_hz, rel=1e-12)
    # Timoshenko on this slender bar: below Euler-Bernoulli, by less than 0.3 % on mode 3
    assert np.all(modes(r, 3).frequencies_hz < exact) and modes(r, 3).frequencies_hz[2] > exact[2] * 0.997


def test_shaker_moving_mass_lowers_the_modes_as_a_lumped_mass():
    L = 0.5
    plain = structure_from_dict(_beam({"a": (0.0, L)}, [], ("a", L), el=0.005, moving=0.02))
    mu = 0.02 / (RHO * A * L)
    # cantilever with a tip mass: 1 + cos b cosh b + mu b (cos b sinh b - sin b cosh b) = 0
    from scipy.optimize import brentq
    g = lambda b: 1 + np.cos(b) * np.cosh(b) + mu * b * (np.cos(b) * np.sinh(b) - np.sin(b) * np.cosh(b))  # noqa: E731
    b1 = brentq(g, 1.0, 1.875)
    exact = b1 ** 2 / (2 * np.pi * L ** 2) * np.sqrt(E * I / (RHO * A))
    assert modes(plain, 1).frequencies_hz[0] == pytest.approx(exact, rel=1e-4)


@pytest.mark.parametrize("k, kt", [(1e5, 1e6), (1e7, 3e4), (1e9, 1e9)])
def test_lap_joint_static_tip_deflection_closed_form(k, kt):
    """Tip load P on a cantilever of two overlapping bars joined at the bolt: the tails past
    the bolt carry nothing, so w_tip = P L^3 / 3EI + P (L - x_b)^2 / k_r + P / k_t with
    k_r = k mean(s_q^2) over the contact's patches (the joint's kinematics)."""
    ov, n = 0.04, 8
    s = structure_from_dict(_lap(k, kt, ov, stations=n))
    L, xb = 0.54 - ov, 0.27 - ov / 2
    arms = ov * ((np.arange(n) + 0.5) / n - 0.5)
    kr = k * np.mean(arms ** 2)
    assert s.joints[0].rotational_stiffness() == pytest.approx(k * ov ** 2 / 12 * (1 - 1 / n ** 2), rel=1e-12)
    assert kr == pytest.approx(s.joints[0].rotational_stiffness(), rel=1e-12)
    w = s.sensors[0] @ np.linalg.solve(s.stiffness(), s.force)
    assert w == pytest.approx(L ** 3 / (3 * E * I) + (L - xb) ** 2 / kr + 1 / kt, rel=1e-6)


def _independent_overlap(l1: float, l2: float, ov: float, el: float) -> np.ndarray:
    """Euler-Bernoulli bars a (clamped at 0) and b sharing the bolt node: a rigid lap joint,
    written here with Hermite elements and merged DOFs (no penalty, no labjoint)."""
    xb = l1 - ov / 2
    xa = np.unique(np.r_[np.linspace(0, l1, int(np.ceil(l1 / el)) + 1), xb])
    xbb = np.unique(np.r_[np.linspace(l1 - ov, l1 - ov + l2, int(np.ceil(l2 / el)) + 1), xb])
    na = xa.size
    ib = int(np.flatnonzero(np.isclose(xbb, xb))[0])
    # global node numbers: a's nodes, then b's except its bolt node (merged with a's)
    ia = int(np.flatnonzero(np.isclose(xa, xb))[0])
    gb = [ia if i == ib else na + i - (i > ib) for i in range(xbb.size)]
    nn = na + xbb.size - 1
    K, M = np.zeros((2 * nn, 2 * nn)), np.zeros((2 * nn, 2 * nn))
    for xs, g in ((xa, list(range(na))), (xbb, gb)):
        for e in range(xs.size - 1):
            h = xs[e + 1] - xs[e]
            ke = E * I / h ** 3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                                            [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
            me = RHO * A * h / 420 * np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                               [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
            d = [2 * g[e], 2 * g[e] + 1, 2 * g[e + 1], 2 * g[e + 1] + 1]
            K[np.ix_(d, d)] += ke
            M[np.ix_(d, d)] += me
    from scipy.linalg import eigh
    w2 = eigh(K[2:, 2:], M[2:, 2:], eigvals_only=True, subset_by_index=(0, 2))
    return np.sqrt(w2) / (2 * np.pi)


def test_rigid_lap_joint_is_one_beam_of_the_combined_length():
    """A rigid joint (1e11: stiff against the bars, still well conditioned) makes the two
    overlapping bars one cantilever of length l1 + l2 - overlap plus the overlapped tails:
    against the independent merged-node model exactly, and against the closed form of the
    uniform cantilever with an error that falls in proportion to the overlap (the tails' mass)."""
    s = structure_from_dict(_lap(1e11, 1e11, 0.05))
    assert modes(s, 3).frequencies_hz == pytest.approx(_independent_overlap(0.27, 0.27, 0.05, 0.01), rel=1e-5)
    exact = BETA_L ** 2 / (2 * np.pi * 0.5 ** 2) * np.sqrt(E * I / (RHO * A))
    err = np.array([modes(structure_from_dict(_lap(1e11, 1e11, ov, l1=0.25 + ov / 2, l2=0.25 + ov / 2)),
                          3).frequencies_hz / exact - 1 for ov in (0.02, 0.01, 0.005)])
    assert np.all(err < 0) and np.all(np.abs(err[-1]) < [3e-3, 1.1e-2, 2e-5])
    ratio = err[1:, :2] / err[:-1, :2]
    assert np.all((ratio > 0.45) & (ratio < 0.56))


def test_lap_joint_stiffness_limits_bracket_the_modes():
    f = [modes(structure_from_dict(_lap(k, 1e12, 0.05)), 2).frequencies_hz for k in (1e4, 1e6, 1e8, 1e11)]
    assert np.all(np.diff(np.array(f), axis=0) > 0)          # stiffer joint, higher modes
    rigid = _independent_overlap(0.27, 0.27, 0.05, 0.01)[:2]
    assert f[-1] == pytest.approx(rigid, rel=1e-4)
    # soft limit: the free bar swings as a rigid body about the bolt on the rotational
    # stiffness k_r = k mean(s_q^2): f = sqrt(k_r / J_b) / 2 pi, J_b its inertia about the bolt
    s = structure_from_dict(_lap(1e2, 1e11, 0.05))
    jb = RHO * A * ((0.27 - 0.025) ** 3 + 0.025 ** 3) / 3
    soft = np.sqrt(s.joints[0].rotational_stiffness() / jb) / (2 * np.pi)
    assert modes(s, 1).frequencies_hz[0] == pytest.approx(soft, rel=2e-3)


def test_lap_joint_law_shear_and_normal_directions():
    """A quadratic (even) law: the mirrored shear arms cancel, the normal direction at the
    contact's edge gives M = (L/2) k2 ((L/2) theta)^2; a cubic (odd) law acts in shear only,
    M = k3 mean(s^4) theta^3."""
    ov = 0.04
    d = _lap(1e6, 1e8, ov, model="linear_stiffness+quadratic_stiffness+cubic_stiffness",
             extra={"quadratic_stiffness.k2": 3e9, "cubic_stiffness.k3": 5e12})
    j = structure_from_dict(d).joints[0]
    fs, n = 2048.0, 2048
    th = 2e-3 * np.sin(2 * np.pi * np.arange(n) / n)
    thd = 2e-3 * 2 * np.pi * fs / n * np.cos(2 * np.pi * np.arange(n) / n)
    m = j.moment_periodic(th, thd, -th * (2 * np.pi * fs / n) ** 2, fs)[0]
    arms = ov * ((np.arange(8) + 0.5) / 8 - 0.5)
    want = (1e6 * np.mean(arms ** 2) * th + 5e12 * np.mean(arms ** 4) * th ** 3
            + ov / 2 * 3e9 * (ov / 2 * th) ** 2)
    assert m == pytest.approx(want, rel=1e-9, abs=1e-12 * np.max(np.abs(want)))


@pytest.mark.parametrize("edit, field", [
    (lambda d: d["sections"]["bar"].update(od_m=0.02), "sections.bar"),
    (lambda d: d["sections"]["bar"].update(h_m=0.0), "sections.bar.h_m"),
    (lambda d: d["sections"].update(bar={"area_m2": 1e-4}), "sections.bar.inertia_m4"),
    (lambda d: d["sections"].update(bar={"type": "ellipse", "b_m": 1.0}), "sections.bar.type"),
    (lambda d: d["components"]["b"].update(x_start_m=0.3), "joints.lap.between"),
    (lambda d: d["joints"][0].update(x_m=0.1), "joints.lap.x_m"),
    (lambda d: d["joints"][0].pop("transverse_stiffness_n_per_m"), "joints.lap.transverse_stiffness_n_per_m"),
    (lambda d: d["joints"][0].update(type="weld"), "joints.lap.type"),
    (lambda d: d["excitation"].update(moving_mass_kg=-0.1), "excitation.moving_mass_kg"),
])
def test_bad_descriptions_name_the_key(edit, field):
    d = _lap(1e6, 1e6, 0.04)
    edit(d)
    with pytest.raises(InputError) as e:
        structure_from_dict(d)
    assert e.value.field == field


# --- stage 1: never an answer that is none ---------------------------------------------------

def test_stage1_refuses_a_parameter_at_its_bound():
    s = structure_from_dict(_lap(1e8, 1e8, 0.03))
    f = modes(s, 1).frequencies_hz[0]
    with pytest.raises(InputError) as e:                      # above what a rigid joint gives
        update_stiffness(s, [1.5 * f], "linear_stiffness.k")
    assert e.value.field == "linear_stiffness.k" and "upper bound" in e.value.message


def test_stage1_refuses_a_parameter_the_frequencies_do_not_see():
    s = structure_from_dict(_lap(1e6, 1e8, 0.03, model="linear_stiffness+cubic_stiffness",
                                 extra={"cubic_stiffness.k3": 1e12}))
    with pytest.raises(InputError) as e:
        update_stiffness(s, [10.0], "cubic_stiffness.k3")
    assert e.value.field == "cubic_stiffness.k3" and "where they were" in e.value.message
    from labjoint.structure.modal import _refuse_non_answers
    f = modes(s, 1).frequencies_hz
    with pytest.raises(InputError) as e:                      # moved 3x, frequencies unchanged
        _refuse_non_answers(s, {"cubic_stiffness.k3": 1e12}, {"cubic_stiffness.k3": 3e12},
                            {"cubic_stiffness.k3": (1e7, 1.1e12 * 10)}, f * 0.9, f, f)
    assert "left the frequencies where they were" in e.value.message


def test_stage1_cli_exit_2_one_line():
    d = tomllib.loads(BERT.read_text())
    p = subprocess.run([sys.executable, "-m", "labjoint.cli.main", "structure", "update", str(BERT),
                        "--measured-hz", "40,200", "--parameter", "linear_stiffness.k", "--json"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 2 and p.stdout == ""
    assert len(p.stderr.strip().splitlines()) == 1 and "bound" in p.stderr
    assert d["joints"][0]["type"] == "lap"


def test_bert_stage1_places_modes_1_and_2_from_a_rigid_start():
    """The shipped BERT file from a rigid joint (1e9 N/m both) to the modes of `labjoint
    modes` on Rand_Rand0p25 (18.696, 97.604 Hz): both placed, the file's values recovered."""
    from labjoint.structure.config import load_structure
    s = load_structure(BERT)
    shipped = {n: s.joints[0].parameter(n) for n in ("linear_stiffness.k", "transverse_stiffness_n_per_m")}
    rigid = with_parameter(with_parameter(s, "linear_stiffness.k", 1e9), "transverse_stiffness_n_per_m", 1e9)
    f0 = modes(rigid, 2).frequencies_hz
    assert f0[0] > 19.0 and f0[1] > 110.0                    # a rigid joint is too stiff
    r = update_stiffness(rigid, [18.696, 97.604], "linear_stiffness.k,transverse_stiffness_n_per_m")
    assert r.updated_hz == pytest.approx([18.696, 97.604], rel=1e-5)
    for n, v in shipped.items():
        assert r.values[n] == pytest.approx(v, rel=2e-3)
    assert modes(s, 2).frequencies_hz == pytest.approx([18.696, 97.604], rel=1e-4)


def test_several_lap_joints_add_their_compliances():
    """Three bars, two lap joints (one with a cubic law, whose stuck stiffness is its
    linear part): w_tip = P L^3 / 3EI + sum_i P (L - x_i)^2 / k_r,i + sum_i P / k_t,i."""
    ov, n = 0.03, 8
    joints = [{"name": "j1", "type": "lap", "between": ["a", "b"], "transverse_stiffness_n_per_m": 2e6,
               "params": {"linear_stiffness.k": 3e6}},
              {"name": "j2", "type": "lap", "between": ["b", "c"], "transverse_stiffness_n_per_m": 5e5,
               "model": "linear_stiffness+cubic_stiffness", "x_m": 0.49,
               "params": {"linear_stiffness.k": 8e5, "cubic_stiffness.k3": 1e12}}]
    comps = {"a": (0.0, 0.27), "b": (0.27 - ov, 0.27), "c": (0.54 - 2 * ov, 0.27)}
    L = 0.81 - 2 * ov
    s = structure_from_dict(_beam(comps, joints, ("c", L)))
    assert [j.name for j in s.joints] == ["j1", "j2"]
    mean_s2 = np.mean((ov * ((np.arange(n) + 0.5) / n - 0.5)) ** 2)
    w = s.sensors[0] @ np.linalg.solve(s.stiffness(), s.force)
    want = (L ** 3 / (3 * E * I) + (L - (0.27 - ov / 2)) ** 2 / (3e6 * mean_s2) + (L - 0.49) ** 2 / (8e5 * mean_s2)
            + 1 / 2e6 + 1 / 5e5)
    assert w == pytest.approx(want, rel=1e-6)


def test_a_joint_stiffer_than_the_model_resolves_is_refused():
    with pytest.raises(InputError) as e:            # 1e13 N/m moved mode 1 by 0.15 %: refused
        structure_from_dict(_lap(1e13, 1e8, 0.05))
    assert e.value.field == "joints.lap.model" and "rotational" in e.value.message
    with pytest.raises(InputError) as e:
        structure_from_dict(_lap(1e8, 1e15, 0.05))
    assert e.value.field == "joints.lap.transverse_stiffness_n_per_m"
