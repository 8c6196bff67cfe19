"""The assembled linear structure: mesh, mass and stiffness, supports, masses, joints' linear
parts, excitation and sensors (all DOFs planar: transverse w and rotation theta per node).

Matrices are dense (a 1-D model of a lab structure has a few hundred DOFs); constrained
DOFs (clamped: w and theta, pinned: w) are removed. ``K0`` holds everything linear except
the joints' tangential laws; :meth:`Structure.stiffness` adds their stuck (linear)
rotational stiffness for modal analysis.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from labjoint.errors import InputError
from labjoint.structure.beam import assemble, element_matrices
from labjoint.structure.joint import Joint
from labjoint.structure.sections import Material, Section

X_TOL = 1e-9


@dataclass(frozen=True)
class Component:
    """A straight beam from ``x_start_m`` over ``length_m`` with one section and material."""

    name: str
    section: Section
    material: Material
    x_start_m: float
    length_m: float

    @property
    def x_end_m(self) -> float:
        return self.x_start_m + self.length_m


@dataclass(frozen=True)
class Damping:
    """Rayleigh (C = alpha M + beta K) or modal (ratio per mode of the linear structure)."""

    kind: str = "none"
    alpha: float = 0.0
    beta: float = 0.0
    ratios: tuple[float, ...] = ()


@dataclass(frozen=True)
class Structure:
    """Kept-DOF matrices and the maps from physical points to them (module docstring)."""

    name: str
    theory: str
    components: tuple[Component, ...]
    node_x: np.ndarray
    node_component: np.ndarray
    dof_index: np.ndarray          # global DOF (2 node + {0: w, 1: theta}) -> kept index or -1
    M: np.ndarray
    K0: np.ndarray
    joints: tuple[Joint, ...]
    force: np.ndarray              # unit force at the excitation point (kept DOFs)
    sensor_names: tuple[str, ...]
    sensors: np.ndarray            # (n_sensors, n) transverse displacement selectors
    damping: Damping = field(default_factory=Damping)

    @property
    def n(self) -> int:
        return self.M.shape[0]

    def dof(self, node: int, which: int) -> int:
        return int(self.dof_index[2 * node + which])

    def selector(self, node_a: int, node_b: int, which: int) -> np.ndarray:
        """Row vector giving (DOF at b) - (DOF at a); a removed DOF counts as zero."""
        s = np.zeros(self.n)
        for node, sign in ((node_b, 1.0), (node_a, -1.0)):
            i = self.dof(node, which)
            if i >= 0:
                s[i] += sign
        return s

    def joint_selectors(self) -> np.ndarray:
        """(n_joints, n): relative rotation theta_b - theta_a of each joint."""
        return np.array([self.selector(j.node_a, j.node_b, 1) for j in self.joints]).reshape(-1, self.n)

    def stiffness(self) -> np.ndarray:
        """K0 plus every joint's stuck rotational stiffness (the linear structure)."""
        K = self.K0.copy()
        for j, s in zip(self.joints, self.joint_selectors()):
            K += j.rotational_stiffness() * np.outer(s, s)
        return K

    def with_joints(self, joints: tuple[Joint, ...]) -> Structure:
        """The same structure with other joints (e.g. an updated stiffness)."""
        K0 = self.K0.copy()
        for old, new in zip(self.joints, joints):
            s = self.selector(old.node_a, old.node_b, 0)
            K0 += (new.transverse_stiffness - old.transverse_stiffness) * np.outer(s, s)
        return replace(self, joints=tuple(joints), K0=K0)

    def damping_matrix(self, K: np.ndarray | None = None) -> np.ndarray:
        """C from the damping spec, built on ``K`` (default: the linear structure)."""
        K = self.stiffness() if K is None else K
        d = self.damping
        if d.kind == "rayleigh":
            return d.alpha * self.M + d.beta * K
        if d.kind == "modal":
            from scipy.linalg import eigh
            w2, phi = eigh(K, self.M)
            w = np.sqrt(np.clip(w2, 0.0, None))
            z = np.array(d.ratios + (d.ratios[-1],) * max(0, w.size - len(d.ratios)))[:w.size]
            Mp = self.M @ phi
            return (Mp * (2 * z * w)) @ Mp.T
        return np.zeros_like(self.M)


def mesh_nodes(comp: Component, points: list[float], element_length: float) -> np.ndarray:
    """Node positions on a component: its ends, every point of interest, and equal
    subdivisions no longer than ``element_length`` between them."""
    xs = np.unique(np.round(np.r_[comp.x_start_m, comp.x_end_m, points], 12))
    out = [xs[:1]]
    for a, b in zip(xs[:-1], xs[1:]):
        m = max(1, int(np.ceil((b - a) / element_length - 1e-9)))
        out.append(np.linspace(a, b, m + 1)[1:])
    return np.concatenate(out)


#: a joint stiffer than this many times the beam's own stiffness at its nodes is beyond
#: what the eigen-solver resolves (1e13 N/m on 5 mm aluminium bars moved mode 1 by 0.15 %)
RIGID_RATIO = 1e4


def _refuse_beyond_rigid(s: Structure, joints: list[Joint]) -> None:
    """InputError naming a joint whose translational or stuck rotational stiffness exceeds
    ``RIGID_RATIO`` x the beam's diagonal stiffness at its nodes (a rigid joint is reached
    well before: 1e2 x already behaves as one)."""
    d = np.diag(s.K0)
    for j in joints:
        for which, k, key in ((0, j.transverse_stiffness, "transverse_stiffness_n_per_m"),
                              (1, j.rotational_stiffness(), "model")):
            beam = max([d[i] for i in (s.dof(j.node_a, which), s.dof(j.node_b, which)) if i >= 0] or [np.inf])
            if k > RIGID_RATIO * beam:
                what = "translational" if which == 0 else "rotational"
                raise InputError(f"the {what} stiffness {k:.3g} is {k / beam:.2g} x the beam's own at the "
                                 f"joint: beyond what the model resolves (at most {RIGID_RATIO:g} x, "
                                 f"{RIGID_RATIO * beam:.3g}; {1e-2 * RIGID_RATIO * beam:.3g} is already rigid)",
                                 field=f"joints.{j.name}.{key}")


def build(name: str, theory: str, components: list[Component], element_length: float,
          points: dict[str, list[float]], supports: list[tuple], masses: list[tuple],
          joints: list[dict], excitation: tuple[str, float],
          sensors: list[tuple[str, str, float]], damping: Damping) -> Structure:
    """Mesh and assemble (points are (component, x_m); see :mod:`labjoint.structure.config`)."""
    node_x, node_comp, first = [], [], []
    start = 0
    for ci, c in enumerate(components):
        x = mesh_nodes(c, points.get(c.name, []), element_length)
        node_x.append(x)
        node_comp.append(np.full(x.size, ci))
        first.append(np.arange(start, start + x.size - 1))
        start += x.size
    node_x, node_comp = np.concatenate(node_x), np.concatenate(node_comp)
    first = np.concatenate(first)
    L = node_x[first + 1] - node_x[first]
    props = [components[ci] for ci in node_comp[first]]
    Ke, Me = element_matrices(
        L, [p.material.E_pa for p in props], [p.material.G_pa for p in props],
        [p.section.area_m2 for p in props], [p.section.inertia_m4 for p in props],
        [p.section.shear_coefficient(p.material.nu) for p in props],
        [p.material.rho_kg_m3 for p in props], theory)
    nd = 2 * node_x.size
    K, M = assemble(first, Ke, Me, nd)
    names = [c.name for c in components]

    def node(comp: str, x: float) -> int:
        ci = names.index(comp)
        hit = np.flatnonzero((node_comp == ci) & (np.abs(node_x - x) < X_TOL))
        return int(hit[0])

    fixed = set()
    for comp, x, kind, kw, kt in supports:
        i = node(comp, x)
        if kind in ("clamped", "pinned"):
            fixed.add(2 * i)
        if kind == "clamped":
            fixed.add(2 * i + 1)
        if kind == "elastic":
            K[2 * i, 2 * i] += kw
            K[2 * i + 1, 2 * i + 1] += kt
    for comp, x, m, jr in masses:
        i = node(comp, x)
        M[2 * i, 2 * i] += m
        M[2 * i + 1, 2 * i + 1] += jr
    keep = np.array([d for d in range(nd) if d not in fixed])
    dof_index = np.full(nd, -1)
    dof_index[keep] = np.arange(keep.size)
    jl = [Joint(node_a=node(j["a"][0], j["a"][1]), node_b=node(j["b"][0], j["b"][1]),
                **{k: v for k, v in j.items() if k not in ("a", "b")}) for j in joints]
    s = Structure(name, theory, tuple(components), node_x, node_comp, dof_index,
                  M[np.ix_(keep, keep)], K[np.ix_(keep, keep)], tuple(jl), np.zeros(keep.size),
                  tuple(n for n, _, _ in sensors), np.zeros((len(sensors), keep.size)), damping)
    _refuse_beyond_rigid(s, jl)
    for j in jl:
        t = s.selector(j.node_a, j.node_b, 0)
        s.K0[:] += j.transverse_stiffness * np.outer(t, t)
    fi = s.dof(node(*excitation), 0)
    if fi < 0:
        raise InputError("the excitation point is on a constrained DOF", field="excitation")
    s.force[fi] = 1.0
    for r, (nm, comp, x) in enumerate(sensors):
        i = s.dof(node(comp, x), 0)
        if i < 0:
            raise InputError("sensor on a constrained DOF (always zero)", field=f"sensors.{nm}")
        s.sensors[r, i] = 1.0
    return s
