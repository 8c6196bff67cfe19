"""Harmonic balance with the alternating frequency-time method (AFT) for hysteretic laws.

x(t) = X_0 + sum_{k=1..H} (X_ck cos k w t + X_sk sin k w t); the unknowns are stored as
(2H+1, n) rows [X_0, X_c1, X_s1, ..., X_cH, X_sH]. The residual per harmonic k is

    (K - (k w)^2 M) X_ck + k w C X_sk + G_ck = F_ck,   (K - (k w)^2 M) X_sk - k w C X_ck + G_sk = F_sk,

with G the Fourier coefficients of the elements' forces: each element's coordinate is
sampled over one period (``samples`` points), its steady force computed in time along
the hysteretic history (:meth:`labjoint.structure.law.JointLaw.periodic`) and projected
back (AFT). The Jacobian of the linear part is exact; the elements' part dG/dQ is
exact (forward mode through the law's rules, :meth:`JointLaw.periodic_tangent`) for
slider and Masing laws (coulomb, iwan, richard_abbott), and otherwise a forward finite
difference per Fourier coefficient of the element coordinate (2H+1 law evaluations per
element, batched), which works for every effect. The excitation is F cos(w t) on the
system's force shape.

Phasor convention: harmonic k of a coordinate is Re(X_k exp(i k w t)) with
X_k = X_ck - i X_sk (X_0 real).
"""

from __future__ import annotations

from collections import OrderedDict
from functools import lru_cache

import numpy as np
from scipy.linalg.lapack import dgetrf, dgetrs

from labjoint.errors import InputError, LabjointError
from labjoint.structure import hbm_kernel as hk
from labjoint.structure.law import PRIME_PERIODS
from labjoint.structure.system import NonlinearSystem

DEFAULT_SAMPLES = 256
NEWTON_MAX = 40
REL_TOL = 1e-9
FD_REL = 1e-6
#: position of the law's parameter matrix in the compiled path's arguments
KERNEL_PM = 10


@lru_cache(maxsize=32)
def _bases(H: int, N: int) -> tuple[np.ndarray, ...]:
    """E (coefficients -> samples), P (samples -> coefficients), D (d/d(wt) on the
    coefficients) and the samples of q, dq/d(wt), d2q/d(wt)^2 from the coefficients (one
    matrix each), read-only and shared by every solver of the same H and N."""
    tau = 2 * np.pi * np.arange(N) / N
    k = np.arange(1, H + 1)
    E = np.ones((N, 2 * H + 1))
    E[:, 1::2] = np.cos(np.outer(tau, k))
    E[:, 2::2] = np.sin(np.outer(tau, k))
    P = E.T * (2.0 / N)
    P[0] /= 2.0
    D = np.zeros((2 * H + 1, 2 * H + 1))
    for kk in k:
        D[2 * kk - 1, 2 * kk] = kk                           # cos coeff of derivative = k X_s
        D[2 * kk, 2 * kk - 1] = -kk                          # sin coeff = -k X_c
    out = (E, P, D, E.T.copy(), (E @ D).T.copy(), (E @ D @ D).T.copy())
    for a in out:
        a.flags.writeable = False
    return out


#: linear matrices kept per system (the last ``LINEAR_CACHE_SYSTEMS`` systems' M, C, K) and
#: w, at most ``LINEAR_CACHE_BYTES`` per system (a continuation's many w do not fill memory)
LINEAR_CACHE_SYSTEMS, LINEAR_CACHE_BYTES = 4, 16 * 2 ** 20
_LINEAR: OrderedDict[tuple, tuple[tuple, dict]] = OrderedDict()


def _linear_cache(sys: NonlinearSystem, H: int) -> dict:
    """The linear matrices by w of a system's M, C, K at H harmonics: a predictor's
    solvers differ only in the joints' law, and the measured steps repeat (the arrays are
    held with their entry, so their ids cannot be reused while it exists)."""
    key = (id(sys.M), id(sys.C), id(sys.K), H)
    hit = _LINEAR.get(key)
    if hit is None:
        hit = _LINEAR[key] = ((sys.M, sys.C, sys.K), {})
        if len(_LINEAR) > LINEAR_CACHE_SYSTEMS:
            _LINEAR.popitem(last=False)
    else:
        _LINEAR.move_to_end(key)
    return hit[1]


def lu_factor(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """LU factors of a dense Jacobian (LAPACK getrf without scipy's per-call checks, which
    had cost as much as the factorisation at these sizes); ValueError if J is not finite,
    LinAlgError if it is singular."""
    if not np.isfinite(J).all():
        raise ValueError("the harmonic-balance Jacobian is not finite")
    lu, piv, info = dgetrf(J)
    if info > 0:
        raise np.linalg.LinAlgError(f"singular harmonic-balance Jacobian (pivot {info})")
    return lu, piv


def lu_solve(f: tuple[np.ndarray, np.ndarray], b: np.ndarray) -> np.ndarray:
    """Solve with :func:`lu_factor`'s factors."""
    return dgetrs(f[0], f[1], b)[0]


class ConvergenceError(LabjointError):
    """A nonlinear solve (Newton, continuation) did not converge; the message says where and why."""


class HarmonicBalance:
    """HBM/AFT for a :class:`NonlinearSystem` with ``harmonics`` H (0..H) (module docstring)."""

    def __init__(self, system: NonlinearSystem, harmonics: int = 5, samples: int | None = None) -> None:
        if isinstance(harmonics, bool) or int(harmonics) != harmonics or not 1 <= harmonics <= 64:
            raise InputError(f"harmonics must be a whole number in [1, 64], got {harmonics!r}",
                             field="harmonics")
        self.sys = system
        self.H = int(harmonics)
        self.N = int(samples or max(DEFAULT_SAMPLES, 8 * self.H))
        if self.N < 2 * self.H + 2:
            raise InputError(f"need more than {2 * self.H + 1} samples per period", field="samples")
        self.E, self.P, self.D, self._to_q, self._to_qd, self._to_qdd = _bases(self.H, self.N)
        self.m = 2 * self.H + 1
        self._force = np.ascontiguousarray(system.force, dtype=float)
        S = np.atleast_2d(system.selectors)
        self._S = S
        # s_e s_e^T of every element, flattened: the elements' Jacobian block in one product
        self._SS = np.einsum("ei,ej->eij", S, S).reshape(S.shape[0], -1)
        self._Z: tuple[float, np.ndarray] | None = None
        self._fast = self._kernel_args()

    def _kernel_args(self) -> tuple | None:
        """The compiled path's arguments (:mod:`labjoint.structure.hbm_kernel`) when every
        element is a joint of one group whose law has kernel terms; otherwise None."""
        els = self.sys.elements
        joints = [getattr(e, "joint", None) for e in els]
        if not els or any(j is None for j in joints) or len(self.groups) != 1:
            return None
        terms = joints[0].law.kernel_terms
        if terms is None:
            return None
        arm, wa, even = joints[0].arms
        return (np.ascontiguousarray(self._S, dtype=float), self._to_q, self._to_qd, self._to_qdd,
                self.P, arm, wa, float(joints[0].normal_arm), bool(even), terms[0], terms[1], PRIME_PERIODS)

    # -- pieces ---------------------------------------------------------------------------
    def linear_matrix(self, w: float, dw: bool = False) -> np.ndarray:
        """Dense matrix of the linear part (or its derivative in w) on the flattened unknowns
        (the last one at a given w is kept: Newton and the Jacobians ask again at one w)."""
        if not dw and self._Z is not None and self._Z[0] == w:
            return self._Z[1]
        cache = _linear_cache(self.sys, self.H) if not dw else None
        if cache is not None and w in cache:
            self._Z = (w, cache[w])
            return cache[w]
        s, n = self.sys, self.sys.n
        Z = np.zeros((self.m * n, self.m * n))
        if not dw:
            Z[:n, :n] = s.K
        for kk in range(1, self.H + 1):
            c, si = slice((2 * kk - 1) * n, 2 * kk * n), slice(2 * kk * n, (2 * kk + 1) * n)
            A = -2 * kk * kk * w * s.M if dw else s.K - (kk * w) ** 2 * s.M
            B = kk * s.C if dw else kk * w * s.C
            Z[c, c], Z[si, si], Z[c, si], Z[si, c] = A, A, B, -B
        if not dw:
            Z.flags.writeable = False
            self._Z = (w, Z)
            if (len(cache) + 1) * Z.nbytes <= LINEAR_CACHE_BYTES:
                cache[w] = Z
        return Z

    def external(self, F: float) -> np.ndarray:
        f = np.zeros((self.m, self.sys.n))
        f[1] = F * self.sys.force
        return f.ravel()

    def _forces(self, e: int, Q: np.ndarray, w: float) -> np.ndarray:
        """(batch, 2H+1) force coefficients of element e for coordinate coefficients Q."""
        Q = np.atleast_2d(Q)
        fs = self.N * w / (2 * np.pi)
        g = self.sys.elements[e].periodic(Q @ self._to_q, (Q @ self._to_qd) * w,
                                          (Q @ self._to_qdd) * (w * w), fs)
        return g @ self.P.T

    def element_forces(self, x: np.ndarray, w: float, jacobian: bool = False
                       ) -> tuple[np.ndarray, np.ndarray | None]:
        """The elements' force coefficients G (2H+1, n_e) at x and, if asked, their
        derivatives dG_k / dQ_l (n_e, 2H+1, 2H+1) in the element's own coefficients Q
        (forward differences, every element of a group and every perturbation in one law call)."""
        m = self.m
        if self._fast is not None:
            G, dG = hk.joint_forces(np.ascontiguousarray(x, dtype=float), self.sys.n, float(w),
                                    *self._fast, jacobian)
            return G.T, (dG if jacobian else None)
        Qall = x.reshape(m, self.sys.n) @ self._S.T              # (2H+1, n_e)
        G = np.empty((m, Qall.shape[1]))
        dG = np.empty((Qall.shape[1], m, m)) if jacobian else None
        groups = self.groups
        if len(groups) == 1 and not jacobian:                    # every element in one law call
            return self._forces(groups[0][0], Qall.T, w).T, None
        for group in groups:
            Qs = Qall[:, group].T                                # (g, 2H+1)
            if not jacobian:
                G[:, group] = self._forces(group[0], Qs, w).T
                continue
            hs = FD_REL * np.maximum(np.linalg.norm(Qs, axis=1), 1e-12)
            T = (self._to_q.T, self._to_qd.T * w, self._to_qdd.T * (w * w))
            g, dg = self.sys.elements[group[0]].periodic_tangent(
                Qs @ self._to_q, (Qs @ self._to_qd) * w, (Qs @ self._to_qdd) * (w * w),
                self.N * w / (2 * np.pi), T, hs)
            G[:, group] = (g @ self.P.T).T
            dG[group] = self.P @ dg                              # (g, 2H+1, 2H+1): dG_k / dQ_l
        return G, dG

    def residual(self, x: np.ndarray, w: float, F: float, jacobian: bool = False
                 ) -> tuple[np.ndarray, np.ndarray | None]:
        """R(x, w) and, if asked, dR/dx (dense)."""
        R, J, _ = self.residual_forces(x, w, F, jacobian)
        return R, J

    def residual_forces(self, x: np.ndarray, w: float, F: float, jacobian: bool = False
                        ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """:meth:`residual` and the elements' force coefficients G (2H+1, n_e) in it."""
        n, m = self.sys.n, self.m
        Z = self.linear_matrix(w)
        if self._fast is not None:
            R, J, G = hk.residual(np.ascontiguousarray(x, dtype=float), float(w), float(F), Z,
                                  self._force, *self._fast, jacobian)
            return R, (J if jacobian else None), G.T
        R = Z @ x
        R[n:2 * n] -= F * self.sys.force
        if not self.sys.elements:
            return R, (Z.copy() if jacobian else None), np.zeros((m, 0))
        G, dG = self.element_forces(x, w, jacobian)
        R += self.spread(G)
        if not jacobian:
            return R, None, G
        # sum_e dG_e (x) s_e s_e^T, laid out on the (harmonic, DOF) unknowns
        Jn = (dG.reshape(dG.shape[0], m * m).T @ self._SS).reshape(m, m, n, n)
        return R, Z + Jn.transpose(0, 2, 1, 3).reshape(m * n, m * n), G

    def sensitivity(self, x: np.ndarray, w: float, F: float, perturbed: list[HarmonicBalance],
                    steps: list[float]) -> np.ndarray:
        """dx/dp (unknowns, n_p) at the solution x by the implicit function theorem,
        -(dR/dx)^-1 dR/dp, where ``perturbed[j]`` is this system with parameter j of the
        law moved by ``steps[j]`` (dR/dp: the change of the elements' forces at fixed x)."""
        if self._fast is not None and all(p._fast is not None for p in perturbed):
            Pms = np.stack([p._fast[KERNEL_PM] for p in perturbed]) if perturbed else \
                np.zeros((0,) + self._fast[KERNEL_PM].shape)
            return hk.sensitivity(np.ascontiguousarray(x, dtype=float), float(w), float(F),
                                  np.asarray(steps, float), Pms, self.linear_matrix(w), self._force,
                                  *self._fast)
        _, J, G0 = self.residual_forces(x, w, F, jacobian=True)
        dR = np.column_stack([self.spread(p.element_forces(x, w)[0] - G0) / d
                              for p, d in zip(perturbed, steps)])
        lu = lu_factor(J)
        # one right-hand side at a time: a multi-column solve goes to level-3 BLAS, whose
        # threads spin on a shared machine (44 ms against 0.1 ms per step, measured)
        return -np.column_stack([lu_solve(lu, dR[:, j]) for j in range(len(steps))])

    def spread(self, G: np.ndarray) -> np.ndarray:
        """Elements' force coefficients (2H+1, n_e) as generalised forces on the unknowns."""
        return (G @ self._S).ravel()

    @property
    def groups(self) -> list[list[int]]:
        """Elements evaluated in one batch: joints with the same law and geometry (the
        threads of one coupling), every other element alone."""
        if getattr(self, "_groups", None) is None:
            keys: dict[object, list[int]] = {}
            for e, el in enumerate(self.sys.elements):
                j = getattr(el, "joint", None)
                key = ((j.law.model.expr, tuple(sorted(j.law.params.items())), j.radius_m, j.stations,
                        j.geometry, j.contact_length_m)
                       if j is not None else ("own", e))
                keys.setdefault(key, []).append(e)
            self._groups = list(keys.values())
        return self._groups

    def d_dw(self, x: np.ndarray, w: float, F: float) -> np.ndarray:
        """dR/dw: exact for the linear part, finite difference for rate-dependent laws."""
        r = self.linear_matrix(w, dw=True) @ x
        if any(e.rate_dependent for e in self.sys.elements):
            dw = 1e-7 * w
            Ra, _ = self.residual(x, w + dw, F)
            Rb, _ = self.residual(x, w, F)
            r = r + (Ra - Rb) / dw - self.linear_matrix(w, dw=True) @ x
        return r

    # -- solving --------------------------------------------------------------------------
    def linear_solution(self, w: float, F: float) -> np.ndarray:
        """The response with every element at its stuck stiffness (a start for Newton)."""
        K = self.sys.linear_stiffness()
        n = self.sys.n
        A = K - w * w * self.sys.M
        B = w * self.sys.C
        big = np.block([[A, B], [-B, A]])
        sol = np.linalg.solve(big, np.r_[F * self.sys.force, np.zeros(n)])
        x = np.zeros((self.m, n))
        x[1], x[2] = sol[:n], sol[n:]
        return x.ravel()

    def solve(self, w: float, F: float, x0: np.ndarray | None = None, tol: float = REL_TOL) -> np.ndarray:
        """Newton (with backtracking) at fixed w; ConvergenceError says where and why."""
        x = self.linear_solution(w, F) if x0 is None else np.array(x0, float)
        scale = max(np.linalg.norm(self.external(F)), 1e-300)
        if self._fast is not None:                  # the same Newton, compiled
            x, r = hk.newton(x, float(w), float(F), float(tol), float(scale), NEWTON_MAX,
                             self.linear_matrix(w), self._force, *self._fast)
            if r < 1e3 * tol:
                return x
            raise ConvergenceError(f"harmonic balance did not converge at {w / (2 * np.pi):.6g} Hz: "
                                   f"relative residual {r:.3g} after {NEWTON_MAX} Newton iterations "
                                   f"(tolerance {tol:.1g})")
        R, _ = self.residual(x, w, F)
        r = np.linalg.norm(R) / scale
        for it in range(NEWTON_MAX):
            if r < tol:
                return x
            _, J = self.residual(x, w, F, jacobian=True)    # only where Newton goes on from
            dx = lu_solve(lu_factor(J), -R)
            lam = 1.0
            while True:
                xn = x + lam * dx
                Rn, _ = self.residual(xn, w, F)
                rn = np.linalg.norm(Rn) / scale
                if rn < r or lam < 1e-3:
                    break
                lam /= 2
            x, R, r = xn, Rn, rn
        if r < 1e3 * tol:
            return x
        raise ConvergenceError(f"harmonic balance did not converge at {w / (2 * np.pi):.6g} Hz: "
                               f"relative residual {r:.3g} after {NEWTON_MAX} Newton iterations "
                               f"(tolerance {tol:.1g})")

    def phasors(self, x: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """Complex phasors (H+1, n_rows) of x mapped by ``rows`` (default: the outputs);
        x may be (unknowns, k) for k solutions at once: (H+1, n_rows, k)."""
        rows = self.sys.outputs if rows is None else rows
        if x.ndim == 2:
            Y = np.einsum("hnk,rn->hrk", x.reshape(self.m, self.sys.n, -1), np.atleast_2d(rows))
        else:
            Y = x.reshape(self.m, self.sys.n) @ np.atleast_2d(rows).T
        out = np.empty((self.H + 1,) + Y.shape[1:], complex)
        out[0] = Y[0]
        out[1:] = Y[1::2] - 1j * Y[2::2]
        return out
