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

Which effects act, and in which direction (issue 32). The patches at +-cos(phi) mirror
each other, so the even part of any law (a force that does not reverse with the motion:
a preload offset, one-sided contact, a gap that closes on one side, asymmetric slip)
cancels in their moment; only the odd part acts in shear. The even part acts in the
normal direction, where bending opens the layer on one side and closes it on the other:
along the opening u_n = r theta of the layer's fibre at phi = 0 (the side in contact),
with moment r E[u_n], E[u] = (F[u] + F[-u]) / 2 the law's even part along the history
(F[-u]: the law along the mirrored history, rates mirrored too). A law made only of
odd effects (``ODD_EFFECTS``) has E = 0 and skips the normal direction; every other
effect, including ones added to the vocabulary later, gets it. So the joint moment is
M = sum_q (1/N_q) r cos(phi_q) F(u_q) + r E[r theta]. Effects that cannot act in a
steady periodic joint are refused by name with the reason (``REFUSED``).

A bolted lap joint (``geometry = "lap"``; issue 29 item 4) has the same kinematics along a
flat interface: two components overlap and the bolt joins them at one point; the contact
of length L around the bolt is ``stations`` equal patches at arms s_q (uniform over
(-L/2, L/2)). A relative rotation theta slides patch q by u_q = s_q theta in the shear
direction of the law, and opens the interface at its edge by u_n = (L/2) theta in the
normal direction, so M = sum_q (1/N) s_q F(s_q theta) + (L/2) E[(L/2) theta] and the stuck
rotational stiffness is k_t mean(s_q^2) = k_t (L^2 / 12) (1 - 1/N^2). The relative
transverse displacement is carried by the translational stiffness ``transverse_stiffness``.

Seed 000 writes the law as stress against strain (Eq. 2: E_e, E_p, S_Y, n); for a layer
of area A = 2 pi r L and thickness h this is the richard_abbott force law with
ke = E_e A / h, kp = E_p A / h, F_y = S_Y A (:func:`layer_params`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from labjoint.errors import InputError
from labjoint.structure.joint_kernel import moment_batch, moment_tangent
from labjoint.structure.law import PRIME_PERIODS, JointLaw

NU_LAYER = 0.3
GEOMETRIES = ("thread", "lap")
#: the joint's translational (transverse) stiffness as an updatable parameter, N/m
TRANSVERSE = "transverse_stiffness_n_per_m"
#: effects whose law is odd (F[-u] = -F[u] along mirrored histories): no normal part
ODD_EFFECTS = frozenset({"linear_stiffness", "viscous", "coulomb", "iwan", "bouc_wen", "valanis",
                         "richard_abbott", "cubic_stiffness", "saturating_stiffness", "inertia",
                         "backlash"})
#: effects that cannot act in a structure's joint, with the reason
REFUSED = {
    "channel_delay": "a time shift between two measured channels, not a force of the joint",
    "wear": "its slip strength keeps falling with the energy dissipated, so the joint has "
            "no steady periodic state for harmonic balance or a step-sine FRF",
}


def refusal(effect: str) -> str | None:
    """Why ``effect`` cannot act in a structure's joint, or None if it can.

    >>> refusal("offset") is None, refusal("wear")[:13]
    (True, 'its slip stre')
    """
    return REFUSED.get(effect)


def check_structure_law(law: JointLaw, field: str = "joint.model") -> None:
    """InputError naming the first effect of ``law`` that cannot act at structure level."""
    for name in law.model.names:
        why = refusal(name)
        if why:
            raise InputError(f"effect '{name}' cannot act in a structure's joint: {why}", field=field)


def has_even_part(law: JointLaw) -> bool:
    """Whether the law may have an even part (any effect not known to be odd)."""
    return any(n not in ODD_EFFECTS for n in law.model.names)


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
    geometry: str = "thread"           # "thread" (seed 000's layer) or "lap" (a flat interface)
    contact_length_m: float = 0.0      # lap: the interface's length along the beam

    def __post_init__(self) -> None:
        if self.geometry not in GEOMETRIES:
            raise InputError(f"must be one of {', '.join(GEOMETRIES)}, got '{self.geometry}'",
                             field=f"joints.{self.name}.type")
        if self.geometry == "lap" and not self.contact_length_m > 0:
            raise InputError(f"a lap joint needs a contact length > 0 m, got {self.contact_length_m}",
                             field=f"joints.{self.name}.contact_length_m")
        if self.stations < 4 or self.stations % 2:
            raise InputError(f"stations must be an even number >= 4, got {self.stations}",
                             field=f"joints.{self.name}.stations")
        check_structure_law(self.law, field=f"joints.{self.name}.model")

    @cached_property
    def station_cos(self) -> tuple[np.ndarray, np.ndarray]:
        """Distinct cos(phi_q) of the patches and their weights (phi and -phi coincide)."""
        n = self.stations
        phi = 2 * np.pi * (np.arange(n // 2) + 0.5) / n
        return np.cos(phi), np.full(n // 2, 2.0 / n)

    @cached_property
    def arms(self) -> tuple[np.ndarray, np.ndarray, bool]:
        """Shear arm (m) of every distinct patch (module docstring), their moment weights
        (share x arm), and whether the law has an even part (computed once: the harmonic
        balance asks per evaluation)."""
        if self.geometry == "lap":
            n = self.stations
            arm, w = self.contact_length_m * ((np.arange(n) + 0.5) / n - 0.5), np.full(n, 1.0 / n)
        else:
            c, w = self.station_cos
            arm = self.radius_m * c
        return arm, w * arm, has_even_part(self.law)

    @property
    def normal_arm(self) -> float:
        """Arm (m) of the normal direction: the thread's radius, or half the lap's contact."""
        return 0.5 * self.contact_length_m if self.geometry == "lap" else self.radius_m

    def rotational_stiffness(self) -> float:
        """Linear (stuck) moment per relative rotation, N m/rad."""
        arm, wa, _ = self.arms
        return float(np.sum(wa * arm) * self.law.initial_stiffness())

    def moment_periodic(self, th: np.ndarray, thd: np.ndarray, thdd: np.ndarray, fs: float) -> np.ndarray:
        """Steady joint moment (N m) over one period of the relative rotation (rad).

        ``th`` etc. may be 2-D (batch, samples) for finite-difference batches."""
        th, thd, thdd = (np.atleast_2d(x) for x in (th, thd, thdd))
        arm, wa, even = self.arms
        r = self.normal_arm
        terms = self.law.kernel_terms
        if terms is not None:                   # the whole joint in one numba call
            return moment_batch(th, thd, thdd, arm, wa, r, even, terms[0], terms[1], PRIME_PERIODS)
        b, q, ns = th.shape[0], arm.size, th.shape[1]
        U, V, A = ((arm[None, :, None] * x[:, None, :]).reshape(b * q, ns) for x in (th, thd, thdd))
        if not even:
            F = self.law.periodic(U, V, A, fs).reshape(b, q, ns)
            return np.einsum("q,bqn->bn", wa, F)
        # the normal direction: the fibre's opening r theta and its mirror, in one batch
        n = np.vstack([U, r * th, -r * th])
        nd = np.vstack([V, r * thd, -r * thd])
        ndd = np.vstack([A, r * thdd, -r * thdd])
        F = self.law.periodic(n, nd, ndd, fs)
        shear = np.einsum("q,bqn->bn", wa, F[:b * q].reshape(b, q, ns))
        even = 0.5 * (F[b * q:b * q + b] + F[b * q + b:])
        return shear + r * even

    def moment_periodic_tangent(self, th: np.ndarray, thd: np.ndarray, thdd: np.ndarray, fs: float,
                                T: tuple[np.ndarray, np.ndarray, np.ndarray], h: np.ndarray
                                ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`moment_periodic` (b, n) and its derivative (b, n, m) in each row's period
        coefficients c, the rotation's samples being T_u c (rates T_v c, T_a c);
        :meth:`labjoint.structure.law.JointLaw.periodic_tangent` with h the steps in c."""
        th, thd, thdd = (np.atleast_2d(x) for x in (th, thd, thdd))
        arm, wa, even = self.arms
        terms = self.law.kernel_terms
        if terms is not None:                   # the whole joint in one numba call
            return moment_tangent(th, thd, thdd, arm, wa, self.normal_arm, even, terms[0], terms[1],
                                  PRIME_PERIODS, T[0], T[1], T[2])
        b, q, ns = th.shape[0], arm.size, th.shape[1]
        U, V, A = ((arm[None, :, None] * x[:, None, :]).reshape(b * q, ns) for x in (th, thd, thdd))
        sc = np.tile(arm, b)
        hh = np.repeat(h, q)
        r = self.normal_arm
        if not even:
            F, dF = self.law.periodic_tangent(U, V, A, fs, sc, T, hh)
            return (np.einsum("q,bqn->bn", wa, F.reshape(b, q, ns)),
                    np.einsum("q,bqnm->bnm", wa, dF.reshape(b, q, ns, -1)))
        F, dF = self.law.periodic_tangent(np.vstack([U, r * th, -r * th]), np.vstack([V, r * thd, -r * thd]),
                                          np.vstack([A, r * thdd, -r * thdd]), fs,
                                          np.concatenate([sc, np.full(b, r), np.full(b, -r)]), T,
                                          np.concatenate([hh, h, h]))
        k = b * q
        return (np.einsum("q,bqn->bn", wa, F[:k].reshape(b, q, ns)) + r * (0.5 * (F[k:k + b] + F[k + b:])),
                np.einsum("q,bqnm->bnm", wa, dF[:k].reshape(b, q, ns, -1)) + r * (0.5 * (dF[k:k + b] + dF[k + b:])))

    def moment_step(self, reversals: np.ndarray, th: float, thd: float, thdd: float) -> float:
        """Joint moment after the past rotation ``reversals`` and a step to ``th``."""
        arm, wa, even = self.arms
        f = [self.law.step_force(a * reversals, a * th, np.array([a * thd]), np.array([a * thdd]))[0]
             for a in arm]
        m = float(np.sum(wa * np.array(f)))
        if even:
            r = self.normal_arm
            fe = [self.law.step_force(s * r * reversals, s * r * th, np.array([s * r * thd]),
                                      np.array([s * r * thdd]))[0] for s in (1.0, -1.0)]
            m += r * 0.5 * (fe[0] + fe[1])
        return m

    def with_parameter(self, name: str, value: float) -> Joint:
        """This joint with a stiffness parameter changed: ``E_e_pa`` (the layer's modulus:
        ke and the transverse tie scale with it), ``transverse_stiffness_n_per_m`` (the tie
        alone) or a law parameter ``effect.param``."""
        if name == "E_e_pa":
            if self.layer is None or self.layer.E_p_pa is None:
                raise InputError("E_e_pa needs a [joints.layer] with the stress law",
                                 field=f"joints.{self.name}.layer")
            layer = replace(self.layer, E_e_pa=float(value))
            A, h = layer.area(self.radius_m), layer.thickness_m
            law = self.law.with_params(**{"richard_abbott.ke": value * A / h})
            kt = self.transverse_stiffness * value / self.layer.E_e_pa
            return replace(self, law=law, layer=layer, transverse_stiffness=kt)
        if name == TRANSVERSE:
            if not value > 0:
                raise InputError(f"must be > 0, got {value!r}", field=TRANSVERSE)
            return replace(self, transverse_stiffness=float(value))
        if name not in self.law.params:
            raise InputError(f"not a parameter of joint '{self.name}' (E_e_pa, {TRANSVERSE} or one of "
                             f"{', '.join(self.law.params)})", field="update.parameter")
        return replace(self, law=self.law.with_params(**{name: value}))

    def parameter(self, name: str) -> float:
        if name == "E_e_pa" and self.layer is not None:
            return float(self.layer.E_e_pa)
        if name in self.law.params:
            return self.law.params[name]
        if name == TRANSVERSE:
            return float(self.transverse_stiffness)
        raise InputError(f"joint '{self.name}' has no parameter '{name}'", field="update.parameter")
