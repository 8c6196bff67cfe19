"""The structural simulator's own beam model: Euler-Bernoulli elements of the pipe
assembly, threads as rotational springs (transverse ties stiff), reduced to a few modes.

Independent of :mod:`labjoint.structure` on purpose: the simulator is the hidden truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh

from labjoint.errors import ConfigError
from labjoint.hardware.sim.structure_config import AssemblyConfig, PipeConfig, ShakerConfig

COMPONENTS = ("short_pipe", "coupling", "long_pipe")
TIE_STIFFNESS = 1e11  # N/m, transverse tie at each thread (rigid on the scale of the modes)


@dataclass(frozen=True)
class Reduced:
    """Modal model: omega (n,), mass-normalised shapes at the drive point, the
    accelerometers and the threads' relative rotations (rows), and the full-model data."""

    omega: np.ndarray
    zeta: np.ndarray
    drive: np.ndarray          # (n,) transverse displacement of the drive point per modal coordinate
    sensors: np.ndarray        # (n_acc, n)
    joints: np.ndarray         # (2, n) relative rotation (coupling minus pipe) per modal coordinate
    sensor_names: tuple[str, ...]

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.omega / (2 * np.pi)


def _section(p: PipeConfig) -> tuple[float, float]:
    ro, ri = p.od_m / 2, p.od_m / 2 - p.wall_m
    return np.pi * (ro**2 - ri**2), np.pi / 4 * (ro**4 - ri**4)


def _element(E: float, I: float, rho_a: float, le: float) -> tuple[np.ndarray, np.ndarray]:
    """Euler-Bernoulli stiffness and consistent mass of one element (w1, t1, w2, t2)."""
    k = E * I / le**3 * np.array([[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le, 2 * le**2],
                                  [-12, -6 * le, 12, -6 * le], [6 * le, 2 * le**2, -6 * le, 4 * le**2]])
    m = rho_a * le / 420 * np.array([[156, 22 * le, 54, -13 * le], [22 * le, 4 * le**2, 13 * le, -3 * le**2],
                                     [54, 13 * le, 156, -22 * le], [-13 * le, -3 * le**2, -22 * le, 4 * le**2]])
    return k, m


def build(a: AssemblyConfig, shaker: ShakerConfig, k_theta: float) -> tuple[np.ndarray, np.ndarray, dict]:
    """Full K, M (clamp applied) and the DOF index of named points; ``k_theta`` per thread."""
    pipes = {"short_pipe": a.short_pipe, "coupling": a.coupling, "long_pipe": a.long_pipe}
    need: dict[str, list[float]] = {c: [] for c in COMPONENTS}
    for x in a.thread_x_m:
        need["coupling"].append(x)
    need["short_pipe"].append(a.thread_x_m[0])
    need["long_pipe"].append(a.thread_x_m[1])
    need["long_pipe"].append(a.excitation_x_m)
    for name, (comp, x) in a.accelerometers.items():
        need[comp].append(x)
    nodes, offset = {}, 0
    for c in COMPONENTS:
        p = pipes[c]
        x0, x1 = p.x_start_m, p.x_start_m + p.length_m
        for x in need[c]:
            if not x0 - 1e-9 <= x <= x1 + 1e-9:
                raise ConfigError(f"x = {x} m is off the {c} ({x0}..{x1} m)", field=f"sim.assembly.{c}")
        n_el = max(1, int(np.ceil(p.length_m / a.element_length_m)))
        xs = np.unique(np.round(np.concatenate([np.linspace(x0, x1, n_el + 1), need[c]]), 9))
        nodes[c] = (xs, offset)
        offset += 2 * xs.size
    K, M = np.zeros((offset, offset)), np.zeros((offset, offset))
    for c in COMPONENTS:
        xs, o = nodes[c]
        A, I = _section(pipes[c])
        for e in range(xs.size - 1):
            k, m = _element(a.E_pa, I, a.rho_kg_m3 * A, xs[e + 1] - xs[e])
            s = slice(o + 2 * e, o + 2 * e + 4)
            K[s, s] += k
            M[s, s] += m

    def dof(comp: str, x: float, rot: bool = False) -> int:
        xs, o = nodes[comp]
        return o + 2 * int(np.argmin(np.abs(xs - x))) + int(rot)

    def spring(i: int, j: int, k: float) -> None:
        K[i, i] += k
        K[j, j] += k
        K[i, j] -= k
        K[j, i] -= k

    joints = []
    for pipe, x in (("short_pipe", a.thread_x_m[0]), ("long_pipe", a.thread_x_m[1])):
        spring(dof(pipe, x), dof("coupling", x), TIE_STIFFNESS)
        spring(dof(pipe, x, True), dof("coupling", x, True), k_theta)
        joints.append((dof("coupling", x, True), dof(pipe, x, True)))
    tip = dof("long_pipe", a.excitation_x_m)
    M[tip, tip] += shaker.armature_mass_kg
    K[tip, tip] += shaker.suspension_stiffness_n_per_m
    sensors = {}
    for name, (comp, x) in a.accelerometers.items():
        sensors[name] = dof(comp, x)
        M[sensors[name], sensors[name]] += a.accelerometer_mass_kg
    keep = np.setdiff1d(np.arange(offset), [dof("short_pipe", 0.0), dof("short_pipe", 0.0, True)])
    index = {i: n for n, i in enumerate(keep)}
    remap = {"drive": index[tip], "sensors": {s: index[i] for s, i in sensors.items()},
             "joints": [(index[i], index[j]) for i, j in joints]}
    return K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], remap


def reduce(a: AssemblyConfig, shaker: ShakerConfig, k_theta: float) -> Reduced:
    """The first ``a.modes`` mass-normalised modes of the assembly with the threads sticking."""
    K, M, idx = build(a, shaker, k_theta)
    w2, phi = eigh(K, M, subset_by_index=[0, a.modes - 1])
    z = np.array([a.damping_ratios[min(i, len(a.damping_ratios) - 1)] for i in range(a.modes)])
    names = tuple(idx["sensors"])
    return Reduced(omega=np.sqrt(w2), zeta=z, drive=phi[idx["drive"]].copy(),
                   sensors=np.array([phi[idx["sensors"][s]] for s in names]),
                   joints=np.array([phi[i] - phi[j] for i, j in idx["joints"]]), sensor_names=names)
