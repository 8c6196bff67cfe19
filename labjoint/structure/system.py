"""The nonlinear system that harmonic balance and time integration solve:

    M x'' + C x' + K x + sum_e s_e^T g_e(s_e x) = F cos(omega t) f

with K everything linear (the joints' laws excluded), s_e the selector of element e's
relative coordinate (a joint's relative rotation, or a single DOF) and g_e its force law
with hysteretic state. Built from a :class:`Structure` (optionally Craig-Bampton
reduced, :mod:`labjoint.structure.reduction`) or, for checks, as a single-DOF oscillator.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from labjoint.structure.assembly import Structure
from labjoint.structure.joint import Joint
from labjoint.structure.law import JointLaw


class Element(Protocol):
    """What an element offers: steady periodic force, force after a step, linear stiffness."""

    rate_dependent: bool

    def periodic(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, fs: float) -> np.ndarray: ...

    def periodic_tangent(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, fs: float,
                         T: tuple, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def step(self, reversals: np.ndarray, q: float, qd: float, qdd: float) -> float: ...

    def stiffness(self) -> float: ...


class LawElement:
    """A tangential law acting directly on one coordinate (force in N on slip in m)."""

    def __init__(self, law: JointLaw) -> None:
        self.law = law
        self.rate_dependent = law.rate_dependent

    def periodic(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, fs: float) -> np.ndarray:
        return self.law.periodic(q, qd, qdd, fs)

    def periodic_tangent(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, fs: float,
                         T: tuple, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = np.atleast_2d(q)
        return self.law.periodic_tangent(q, qd, qdd, fs, np.ones(q.shape[0]), T, h)

    def step(self, reversals: np.ndarray, q: float, qd: float, qdd: float) -> float:
        return float(self.law.step_force(reversals, q, np.array([qd]), np.array([qdd]))[0])

    def stiffness(self) -> float:
        return self.law.initial_stiffness()


class JointElement:
    """A structure joint: moment (N m) on relative rotation (rad), :mod:`labjoint.structure.joint`."""

    def __init__(self, joint: Joint) -> None:
        self.joint = joint
        self.rate_dependent = joint.law.rate_dependent

    def periodic(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, fs: float) -> np.ndarray:
        return self.joint.moment_periodic(q, qd, qdd, fs)

    def periodic_tangent(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, fs: float,
                         T: tuple, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.joint.moment_periodic_tangent(q, qd, qdd, fs, T, h)

    def step(self, reversals: np.ndarray, q: float, qd: float, qdd: float) -> float:
        return self.joint.moment_step(reversals, q, qd, qdd)

    def stiffness(self) -> float:
        return self.joint.rotational_stiffness()


@dataclass(frozen=True)
class NonlinearSystem:
    """Matrices (n x n), unit force shape, element selectors (n_e x n), outputs (n_out x n)."""

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    force: np.ndarray
    selectors: np.ndarray
    elements: tuple
    outputs: np.ndarray
    output_names: tuple[str, ...]

    @property
    def n(self) -> int:
        return self.M.shape[0]

    def linear_stiffness(self) -> np.ndarray:
        """K plus every element's stuck stiffness (the linearised system)."""
        K = self.K.copy()
        for s, e in zip(self.selectors, self.elements):
            K += e.stiffness() * np.outer(s, s)
        return K

    @classmethod
    def sdof(cls, m: float, c: float, k: float, law: JointLaw) -> NonlinearSystem:
        """m x'' + c x' + k x + g(x) = F cos(omega t): one mass on a law to ground."""
        one = np.ones((1, 1))
        return cls(m * one, c * one, k * one, np.ones(1), one.copy(), (LawElement(law),), one.copy(), ("x",))

    @classmethod
    def from_structure(cls, structure: Structure) -> NonlinearSystem:
        """The unreduced structure: every DOF kept."""
        C = structure.damping_matrix()
        return cls(structure.M, C, structure.K0, structure.force, structure.joint_selectors(),
                   tuple(JointElement(j) for j in structure.joints), structure.sensors,
                   structure.sensor_names)
