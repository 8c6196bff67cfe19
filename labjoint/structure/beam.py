"""Planar 1-D beam elements (transverse w, rotation theta per node), vectorised over elements.

Timoshenko element with interdependent interpolation (exact static stiffness, consistent
translational and rotary mass; Przemieniecki 1968), phi = 12 E I / (kappa G A L^2).
Euler-Bernoulli is phi = 0 without rotary inertia (the check). Node DOFs are ordered
(w, theta); an element couples nodes i and i + 1.
"""

from __future__ import annotations

import numpy as np

from labjoint.errors import InputError

THEORIES = ("timoshenko", "euler_bernoulli")


def element_matrices(L: np.ndarray, E: np.ndarray, G: np.ndarray, A: np.ndarray, I: np.ndarray,
                     kappa: np.ndarray, rho: np.ndarray, theory: str = "timoshenko"
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass (each (n_el, 4, 4)) of elements with per-element properties."""
    if theory not in THEORIES:
        raise InputError(f"beam theory must be one of {', '.join(THEORIES)}, got '{theory}'",
                         field="structure.beam")
    L, E, G, A, I, kappa, rho = (np.broadcast_to(np.asarray(x, float), np.shape(L))
                                 for x in (L, E, G, A, I, kappa, rho))
    timo = theory == "timoshenko"
    phi = 12.0 * E * I / (kappa * G * A * L ** 2) if timo else np.zeros_like(L)
    p2 = phi * phi
    n = L.size
    K = np.empty((n, 4, 4))
    c = (E * I / ((1.0 + phi) * L ** 3))
    kk = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], float)
    lp = np.array([0, 1, 0, 1])                                  # powers of L per index
    Lp = L[:, None, None] ** (lp[None, :, None] + lp[None, None, :])
    K[:] = kk
    K[:, 1, 1] = K[:, 3, 3] = 4.0 + phi
    K[:, 1, 3] = K[:, 3, 1] = 2.0 - phi
    K *= (c[:, None, None] * Lp)
    # translational consistent mass
    a1 = 13 / 35 + 7 * phi / 10 + p2 / 3
    a2 = 11 / 210 + 11 * phi / 120 + p2 / 24
    a3 = 9 / 70 + 3 * phi / 10 + p2 / 6
    a4 = 13 / 420 + 3 * phi / 40 + p2 / 24
    a5 = 1 / 105 + phi / 60 + p2 / 120
    a6 = 1 / 140 + phi / 60 + p2 / 120
    Mt = np.stack([np.stack([a1, a2, a3, -a4], -1), np.stack([a2, a5, a4, -a6], -1),
                   np.stack([a3, a4, a1, -a2], -1), np.stack([-a4, -a6, -a2, a5], -1)], -2)
    M = Mt * Lp * (rho * A * L / (1.0 + phi) ** 2)[:, None, None]
    if timo:
        b1 = np.full_like(L, 6 / 5)
        b2 = 1 / 10 - phi / 2
        b3 = 2 / 15 + phi / 6 + p2 / 3
        b4 = -1 / 30 - phi / 6 + p2 / 6
        Mr = np.stack([np.stack([b1, b2, -b1, b2], -1), np.stack([b2, b3, -b2, b4], -1),
                       np.stack([-b1, -b2, b1, -b2], -1), np.stack([b2, b4, -b2, b3], -1)], -2)
        M = M + Mr * Lp * (rho * I / ((1.0 + phi) ** 2 * L))[:, None, None]
    return K, M


def assemble(first_node: np.ndarray, Ke: np.ndarray, Me: np.ndarray, n_dof: int
             ) -> tuple[np.ndarray, np.ndarray]:
    """Dense global K, M from element matrices; element e joins nodes first_node[e] and +1."""
    dofs = 2 * np.asarray(first_node)[:, None] + np.arange(4)[None, :]
    rows = np.repeat(dofs, 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 4)).ravel()
    K = np.zeros((n_dof, n_dof))
    M = np.zeros((n_dof, n_dof))
    np.add.at(K, (rows, cols), Ke.ravel())
    np.add.at(M, (rows, cols), Me.ravel())
    return K, M
