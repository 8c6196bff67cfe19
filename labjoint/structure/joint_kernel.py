"""A joint's steady moment over one period for a batch of rotation histories, in one numba
call (issue 32 item 6): the patches' slips r cos(phi_q) theta and, for a law with an even
part, the normal opening +-r theta (:mod:`labjoint.structure.joint`, whose docstring gives
the kinematics), through the batched law kernel
(:func:`labjoint.models.effects._steady.steady_batch` / ``steady_tangent``), summed with
the patches' weights. The same sums as :meth:`Joint.moment_periodic` without the Python
calls per evaluation that had cost more than the law itself.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from labjoint.models.effects._steady import steady_batch, steady_tangent


@njit(cache=True)
def _rows(th, thd, thdd, arm, r, even):  # pragma: no cover - numba
    b, n = th.shape
    q = arm.size
    rows = b * q + (2 * b if even else 0)
    U = np.empty((rows, n))
    V = np.empty((rows, n))
    A = np.empty((rows, n))
    s = np.empty(rows)
    for i in range(b):
        for k in range(q):
            s[i * q + k] = arm[k]
        if even:
            s[b * q + i] = r
            s[b * q + b + i] = -r
    for i in range(rows):
        src = i // q if i < b * q else (i - b * q) % b
        for j in range(n):
            U[i, j] = s[i] * th[src, j]
            V[i, j] = s[i] * thd[src, j]
            A[i, j] = s[i] * thdd[src, j]
    return U, V, A, s


@njit(cache=True)
def moment_batch(th, thd, thdd, arm, wa, r, even, codes, P, prime):  # pragma: no cover - numba
    """(b, n) joint moment for rotation histories ``th`` (b, n) and their rates."""
    b, n = th.shape
    q = arm.size
    U, V, A, _ = _rows(th, thd, thdd, arm, r, even)
    F = steady_batch(U, V, A, codes, P, prime)
    M = np.zeros((b, n))
    for i in range(b):
        for k in range(q):
            for j in range(n):
                M[i, j] += wa[k] * F[i * q + k, j]
        if even:
            for j in range(n):
                M[i, j] += r * (0.5 * (F[b * q + i, j] + F[b * q + b + i, j]))
    return M


@njit(cache=True)
def moment_tangent(th, thd, thdd, arm, wa, r, even, codes, P, prime, T, Tv, Ta):  # pragma: no cover
    """:func:`moment_batch` and its derivative (b, n, m) in each row's period coefficients
    c (theta = T c, its rates Tv c, Ta c)."""
    b, n = th.shape
    q = arm.size
    m = T.shape[1]
    U, V, A, s = _rows(th, thd, thdd, arm, r, even)
    F, dF = steady_tangent(U, V, A, s, T, Tv, Ta, codes, P, prime)
    M = np.zeros((b, n))
    dM = np.zeros((b, n, m))
    for i in range(b):
        for k in range(q):
            for j in range(n):
                M[i, j] += wa[k] * F[i * q + k, j]
                for c in range(m):
                    dM[i, j, c] += wa[k] * dF[i * q + k, j, c]
        if even:
            for j in range(n):
                M[i, j] += r * (0.5 * (F[b * q + i, j] + F[b * q + b + i, j]))
                for c in range(m):
                    dM[i, j, c] += r * (0.5 * (dF[b * q + i, j, c] + dF[b * q + b + i, j, c]))
    return M, dM
