"""Harmonic balance of a structure whose joints share one law of kernel terms, compiled
(issue 32 item 6): the residual, its Jacobian and the whole Newton solve of
:class:`labjoint.structure.hbm.HarmonicBalance` (same equations, same steps: full Newton
with the same backtracking and tolerances) in one numba call per step, the joints' moment
from :mod:`labjoint.structure.joint_kernel`. What is left in Python per step had been
most of a structure diagnosis's time. ``HarmonicBalance`` uses it when every element is a
joint of one group (the threads of one coupling) whose law has kernel terms, and its own
Python path otherwise.

``args`` = (S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes, Pm, prime): the elements'
selectors (E, n), the Fourier bases (:func:`labjoint.structure.hbm._bases`), the joints'
lever arms and weights, radius, whether the law has an even part, and its kernel terms.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from labjoint.structure.joint_kernel import moment_batch, moment_tangent


@njit(cache=True)
def joint_forces(x, n, w, S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes, Pm, prime,
                 tangent):  # pragma: no cover - numba
    """The joints' force coefficients G (E, 2H+1) at x and, if ``tangent``, dG (E, m, m)."""
    m = to_q.shape[0]
    X = x.reshape(m, n)
    Q = np.ascontiguousarray((X @ S.T).T)                  # (E, m)
    th = Q @ to_q
    thd = (Q @ to_qd) * w
    thdd = (Q @ to_qdd) * (w * w)
    E = Q.shape[0]
    dG = np.zeros((E, m, m))
    if tangent:
        M, dM = moment_tangent(th, thd, thdd, arm, wa, r, even, codes, Pm, prime,
                               np.ascontiguousarray(to_q.T), np.ascontiguousarray(to_qd.T) * w,
                               np.ascontiguousarray(to_qdd.T) * (w * w))
        for e in range(E):
            dG[e] = P @ np.ascontiguousarray(dM[e])
    else:
        M = moment_batch(th, thd, thdd, arm, wa, r, even, codes, Pm, prime)
    return M @ P.T, dG


@njit(cache=True)
def residual(x, w, F, Z, force, S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes, Pm, prime,
             jacobian):  # pragma: no cover - numba
    """R (m n,), dR/dx (m n, m n; empty unless ``jacobian``) and G (E, m)."""
    n = force.size
    m = to_q.shape[0]
    R = Z @ x
    for i in range(n):
        R[n + i] -= F * force[i]
    G, dG = joint_forces(x, n, w, S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes, Pm, prime,
                         jacobian)
    E = S.shape[0]
    for k in range(m):
        for e in range(E):
            g = G[e, k]
            for i in range(n):
                R[k * n + i] += g * S[e, i]
    if not jacobian:
        return R, np.empty((0, 0)), G
    J = Z.copy()
    for e in range(E):
        nz = np.nonzero(S[e])[0]                 # a selector touches a few DOFs only
        for k in range(m):
            for l in range(m):
                c = dG[e, k, l]
                if c == 0.0:
                    continue
                for i in nz:
                    si = c * S[e, i]
                    for j in nz:
                        J[k * n + i, l * n + j] += si * S[e, j]
    return R, J, G


@njit(cache=True)
def newton(x0, w, F, tol, scale, newton_max, Z, force, S, to_q, to_qd, to_qdd, P, arm, wa, r, even,
           codes, Pm, prime):  # pragma: no cover - numba
    """:meth:`HarmonicBalance.solve`'s Newton with backtracking: (x, relative residual)."""
    x = x0.copy()
    R = residual(x, w, F, Z, force, S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes, Pm, prime,
                 False)[0]
    rr = np.linalg.norm(R) / scale
    for _ in range(newton_max):
        if rr < tol:
            return x, rr
        J = residual(x, w, F, Z, force, S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes, Pm,
                     prime, True)[1]
        dx = np.linalg.solve(J, -R)
        lam = 1.0
        while True:
            xn = x + lam * dx
            Rn = residual(xn, w, F, Z, force, S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes,
                          Pm, prime, False)[0]
            rn = np.linalg.norm(Rn) / scale
            if rn < rr or lam < 1e-3:
                break
            lam /= 2
        x, R, rr = xn, Rn, rn
    return x, rr


@njit(cache=True)
def sensitivity(x, w, F, d, Pms, Z, force, S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes, Pm,
                prime):  # pragma: no cover - numba
    """dx/dp (m n, n_p) at the solution x by the implicit function theorem:
    -(dR/dx)^-1 dR/dp, dR/dp the change of the joints' forces at fixed x when the law's
    parameter matrix is ``Pms[j]`` (parameter j moved by ``d[j]``)."""
    n = force.size
    m = to_q.shape[0]
    _, J, G0 = residual(x, w, F, Z, force, S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes, Pm,
                        prime, True)
    E = S.shape[0]
    dR = np.zeros((x.size, d.size))
    for j in range(d.size):
        Gj = joint_forces(x, n, w, S, to_q, to_qd, to_qdd, P, arm, wa, r, even, codes, Pms[j], prime,
                          False)[0]
        for k in range(m):
            for e in range(E):
                g = (Gj[e, k] - G0[e, k]) / d[j]
                for i in range(n):
                    dR[k * n + i, j] += g * S[e, i]
    return -np.linalg.solve(J, dR)
