"""The joint element: a thin layer at the thread between two components (seed 000).

Kinematics (1-D, planar bending): the layer is a cylinder of radius r between the two
parts, discretised into ``stations`` equal patches around the circumference at angles
phi_q. A relative rotation theta = theta_b - theta_a slides patch q tangentially
(along the axis) by u_q = r cos(phi_q) theta; every patch carries its share 1/N_q of
the tangential law F(u) (the force of the whole layer if it all slid by u), and the
joint moment is M = sum_q (1/N_q) r cos(phi_q) F(u_q). Patches therefore slip in turn
(micro-slip from the layer's geometry, as the thin layer of solid elements does in
seed 000). Linear check: M = (r^2 / 2) k_t theta, k_t the law's stuck stiffness.
A relative transverse displacement is carried by a linear tie (the layer's normal and
shear stiffness), ``transverse_stiffness``.

Seed 000 writes the law as stress against strain (Eq. 2: E_e, E_p, S_Y, n); for a layer
of area A = 2 pi r L and thickness h this is the richard_abbott force law with
ke = E_e A / h, kp = E_p A / h, F_y = S_Y A (:func:`layer_params`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from labjoint.errors import InputError
from labjoint.structure.law import JointLaw

NU_LAYER = 0.3


@dataclass(frozen=True)
class Layer:
    """Thin-layer geometry (m) and seed 000's stress-law parameters (Pa, shape n)."""

    length_m: float
    thickness_m: float
    E_e_pa: float
    E_p_pa: float | None = None
    S_Y_pa: float | None = None
    n: float | None = None

    def area(self, radius_m: float) -> float:
        return 2.0 * np.pi * radius_m * self.length_m


def layer_params(layer: Layer, radius_m: float) -> dict[str, float]:
    """richard_abbott parameters (N/m, N) of a layer's stress law (seed 000 Eq. 2)."""
    A, h = layer.area(radius_m), layer.thickness_m
    return {"richard_abbott.ke": layer.E_e_pa * A / h, "richard_abbott.kp": layer.E_p_pa * A / h,
            "richard_abbott.F_y": layer.S_Y_pa * A, "richard_abbott.n": layer.n}


def layer_transverse_stiffness(layer: Layer, radius_m: float) -> float:
    """Transverse stiffness (N/m) of the layer: pi r L (E + G) / h (normal plus shear)."""
    E = layer.E_e_pa
    return float(np.pi * radius_m * layer.length_m * (E + E / (2 * (1 + NU_LAYER))) / layer.thickness_m)


@dataclass(frozen=True)
class Joint:
    """A joint between node ``a`` and node ``b`` (global node indices) with a tangential law."""

    name: str
    node_a: int
    node_b: int
    law: JointLaw
    radius_m: float
    stations: int
    transverse_stiffness: float
    layer: Layer | None = None

    def __post_init__(self) -> None:
        if self.stations < 4 or self.stations % 2:
            raise InputError(f"stations must be an even number >= 4, got {self.stations}",
                             field=f"joints.{self.name}.stations")

    @property
    def station_cos(self) -> tuple[np.ndarray, np.ndarray]:
        """Distinct cos(phi_q) of the patches and their weights (phi and -phi coincide)."""
        n = self.stations
        phi = 2 * np.pi * (np.arange(n // 2) + 0.5) / n
        return np.cos(phi), np.full(n // 2, 2.0 / n)

    def rotational_stiffness(self) -> float:
        """Linear (stuck) moment per relative rotation, N m/rad."""
        c, w = self.station_cos
        return float(self.radius_m ** 2 * np.sum(w * c * c) * self.law.initial_stiffness())

    def moment_periodic(self, th: np.ndarray, thd: np.ndarray, thdd: np.ndarray, fs: float) -> np.ndarray:
        """Steady joint moment (N m) over one period of the relative rotation (rad).

        ``th`` etc. may be 2-D (batch, samples) for finite-difference batches."""
        th, thd, thdd = (np.atleast_2d(x) for x in (th, thd, thdd))
        c, w = self.station_cos
        arm = self.radius_m * c                                   # (q,)
        b = th.shape[0]
        U = (arm[None, :, None] * th[:, None, :]).reshape(b * c.size, -1)
        V = (arm[None, :, None] * thd[:, None, :]).reshape(b * c.size, -1)
        A = (arm[None, :, None] * thdd[:, None, :]).reshape(b * c.size, -1)
        F = self.law.periodic(U, V, A, fs).reshape(b, c.size, -1)
        return np.einsum("q,bqn->bn", w * arm, F)

    def moment_step(self, reversals: np.ndarray, th: float, thd: float, thdd: float) -> float:
        """Joint moment after the past rotation ``reversals`` and a step to ``th``."""
        c, w = self.station_cos
        arm = self.radius_m * c
        f = [self.law.step_force(a * reversals, a * th, np.array([a * thd]), np.array([a * thdd]))[0]
             for a in arm]
        return float(np.sum(w * arm * np.array(f)))

    def with_parameter(self, name: str, value: float) -> Joint:
        """This joint with a stiffness parameter changed: ``E_e_pa`` (the layer's modulus:
        ke and the transverse tie scale with it) or a law parameter ``effect.param``."""
        if name == "E_e_pa":
            if self.layer is None or self.layer.E_p_pa is None:
                raise InputError("E_e_pa needs a [joints.layer] with the stress law",
                                 field=f"joints.{self.name}.layer")
            layer = replace(self.layer, E_e_pa=float(value))
            A, h = layer.area(self.radius_m), layer.thickness_m
            law = self.law.with_params(**{"richard_abbott.ke": value * A / h})
            kt = self.transverse_stiffness * value / self.layer.E_e_pa
            return replace(self, law=law, layer=layer, transverse_stiffness=kt)
        if name not in self.law.params:
            raise InputError(f"not a parameter of joint '{self.name}' (E_e_pa or one of "
                             f"{', '.join(self.law.params)})", field="update.parameter")
        return replace(self, law=self.law.with_params(**{name: value}))

    def parameter(self, name: str) -> float:
        if name == "E_e_pa" and self.layer is not None:
            return float(self.layer.E_e_pa)
        if name in self.law.params:
            return self.law.params[name]
        raise InputError(f"joint '{self.name}' has no parameter '{name}'", field="update.parameter")
