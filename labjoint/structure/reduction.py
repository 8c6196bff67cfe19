"""Craig-Bampton reduction (seed 000 Eqs. 4-6) with the joint DOFs kept physical.

The DOFs of every joint node are the boundary set b; all others are interior i. The
transformation x = T [eta; x_b] has the lowest ``n_modes`` fixed-interface normal modes
phi (K_ii phi = omega^2 M_ii phi, boundary held) and the constraint modes
psi = -K_ii^-1 K_ib (Eq. 6); the reduced matrices are T^T [M, K, C] T and the force
T^T f (Eq. 5). The joints' laws act on the boundary DOFs, which stay physical, so the
nonlinear system keeps its form; sensors are recovered through T.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve, eigh

from labjoint.errors import InputError
from labjoint.structure.assembly import Structure
from labjoint.structure.system import JointElement, NonlinearSystem


@dataclass(frozen=True)
class Reduction:
    """T (n x r), the boundary DOF indices, and the number of kept modes."""

    T: np.ndarray
    boundary: np.ndarray
    n_modes: int


def boundary_dofs(structure: Structure) -> np.ndarray:
    """Kept-DOF indices of every joint node (w and theta)."""
    b = [structure.dof(node, w) for j in structure.joints for node in (j.node_a, j.node_b) for w in (0, 1)]
    return np.unique([i for i in b if i >= 0])


def craig_bampton(structure: Structure, n_modes: int) -> Reduction:
    """The Craig-Bampton transformation of the structure without the joints' laws."""
    b = boundary_dofs(structure)
    if b.size == 0:
        raise InputError("Craig-Bampton needs joint DOFs to keep; the structure has no joint",
                         field="joints")
    i = np.setdiff1d(np.arange(structure.n), b)
    if isinstance(n_modes, bool) or int(n_modes) != n_modes or not 0 <= n_modes <= i.size:
        raise InputError(f"kept modes must be a whole number in [0, {i.size}], got {n_modes!r}",
                         field="modes")
    K, M = structure.K0, structure.M
    Kii, Kib, Mii = K[np.ix_(i, i)], K[np.ix_(i, b)], M[np.ix_(i, i)]
    try:
        cf = cho_factor(Kii)
    except np.linalg.LinAlgError:
        raise InputError("with the joint DOFs held, a component can still move as a rigid body; "
                         "support it or join it", field="joints") from None
    psi = -cho_solve(cf, Kib)
    T = np.zeros((structure.n, int(n_modes) + b.size))
    if n_modes:
        _, phi = eigh(Kii, Mii, subset_by_index=(0, int(n_modes) - 1))
        T[np.ix_(i, np.arange(n_modes))] = phi
    T[np.ix_(i, n_modes + np.arange(b.size))] = psi
    T[b, n_modes + np.arange(b.size)] = 1.0
    return Reduction(T, b, int(n_modes))


def reduced_system(structure: Structure, n_modes: int) -> tuple[NonlinearSystem, Reduction]:
    """The nonlinear system on Craig-Bampton coordinates (damping reduced from the full C)."""
    red = craig_bampton(structure, n_modes)
    T = red.T
    C = structure.damping_matrix()
    sysr = NonlinearSystem(T.T @ structure.M @ T, T.T @ C @ T, T.T @ structure.K0 @ T,
                           T.T @ structure.force, structure.joint_selectors() @ T,
                           tuple(JointElement(j) for j in structure.joints),
                           structure.sensors @ T, structure.sensor_names)
    return sysr, red
