"""Harmonic balance with the alternating frequency-time method (AFT) for hysteretic laws.

x(t) = X_0 + sum_{k=1..H} (X_ck cos k w t + X_sk sin k w t); the unknowns are stored as
(2H+1, n) rows [X_0, X_c1, X_s1, ..., X_cH, X_sH]. The residual per harmonic k is

    (K - (k w)^2 M) X_ck + k w C X_sk + G_ck = F_ck,   (K - (k w)^2 M) X_sk - k w C X_ck + G_sk = F_sk,

with G the Fourier coefficients of the elements' forces: each element's coordinate is
sampled over one period (``samples`` points), its steady force computed in time along
the hysteretic history (:meth:`labjoint.structure.law.JointLaw.periodic`) and projected
back (AFT). The Jacobian of the linear part is exact; the elements' part dG/dQ is a
forward finite difference per Fourier coefficient of the element coordinate (2H+1 law
evaluations per element, batched), which works for every effect. The excitation is
F cos(w t) on the system's force shape.

Phasor convention: harmonic k of a coordinate is Re(X_k exp(i k w t)) with
X_k = X_ck - i X_sk (X_0 real).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from labjoint.errors import InputError, LabjointError
from labjoint.structure.system import NonlinearSystem

DEFAULT_SAMPLES = 256
NEWTON_MAX = 40
REL_TOL = 1e-9
FD_REL = 1e-6


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
        tau = 2 * np.pi * np.arange(self.N) / self.N
        k = np.arange(1, self.H + 1)
        E = np.ones((self.N, 2 * self.H + 1))
        E[:, 1::2] = np.cos(np.outer(tau, k))
        E[:, 2::2] = np.sin(np.outer(tau, k))
        self.E = E                                           # coefficients -> samples
        self.P = E.T * (2.0 / self.N)                        # samples -> coefficients
        self.P[0] /= 2.0
        D = np.zeros((2 * self.H + 1, 2 * self.H + 1))       # d/d(w t) on coefficients
        for kk in k:
            D[2 * kk - 1, 2 * kk] = kk                       # cos coeff of derivative = k X_s
            D[2 * kk, 2 * kk - 1] = -kk                      # sin coeff = -k X_c
        self.D = D
        self.m = 2 * self.H + 1

    # -- pieces ---------------------------------------------------------------------------
    def linear_matrix(self, w: float, dw: bool = False) -> np.ndarray:
        """Dense matrix of the linear part (or its derivative in w) on the flattened unknowns."""
        s, n = self.sys, self.sys.n
        Z = np.zeros((self.m * n, self.m * n))
        if not dw:
            Z[:n, :n] = s.K
        for kk in range(1, self.H + 1):
            c, si = slice((2 * kk - 1) * n, 2 * kk * n), slice(2 * kk * n, (2 * kk + 1) * n)
            A = -2 * kk * kk * w * s.M if dw else s.K - (kk * w) ** 2 * s.M
            B = kk * s.C if dw else kk * w * s.C
            Z[c, c], Z[si, si], Z[c, si], Z[si, c] = A, A, B, -B
        return Z

    def external(self, F: float) -> np.ndarray:
        f = np.zeros((self.m, self.sys.n))
        f[1] = F * self.sys.force
        return f.ravel()


    def _forces(self, e: int, Q: np.ndarray, w: float) -> np.ndarray:
        """(batch, 2H+1) force coefficients of element e for coordinate coefficients Q."""
        Q = np.atleast_2d(Q)
        q = Q @ self.E.T
        qd = (Q @ self.D.T) @ self.E.T * w
        qdd = (Q @ (self.D @ self.D).T) @ self.E.T * w * w
        fs = self.N * w / (2 * np.pi)
        g = self.sys.elements[e].periodic(q, qd, qdd, fs)
        return g @ self.P.T

    def residual(self, x: np.ndarray, w: float, F: float, jacobian: bool = False
                 ) -> tuple[np.ndarray, np.ndarray | None]:
        """R(x, w) and, if asked, dR/dx (dense)."""
        n = self.sys.n
        Z = self.linear_matrix(w)
        R = Z @ x - self.external(F)
        J = Z if jacobian else None
        X = x.reshape(self.m, n)
        sel = self.sys.selectors
        for group in self.groups:
            Qs = [X @ sel[e] for e in group]
            if not jacobian:
                rows = [Q[None, :] for Q in Qs]
            else:
                hs = [FD_REL * max(np.linalg.norm(Q), 1e-12) for Q in Qs]
                rows = [np.vstack([Q, Q + h * np.eye(self.m)]) for Q, h in zip(Qs, hs)]
            Gall = self._forces(group[0], np.vstack(rows), w)      # one law call per group
            k = 0
            for i, e in enumerate(group):
                Gb = Gall[k:k + rows[i].shape[0]]
                k += rows[i].shape[0]
                G = Gb[0]
                if jacobian:
                    dG = ((Gb[1:] - G) / hs[i]).T                # (2H+1, 2H+1): dG_k / dQ_l
                    J = J + np.kron(dG, np.outer(sel[e], sel[e]))
                R = R + np.outer(G, sel[e]).ravel()
        return R, J

    @property
    def groups(self) -> list[list[int]]:
        """Elements evaluated in one batch: joints with the same law and geometry (the
        threads of one coupling), every other element alone."""
        if getattr(self, "_groups", None) is None:
            keys: dict[object, list[int]] = {}
            for e, el in enumerate(self.sys.elements):
                j = getattr(el, "joint", None)
                key = ((j.law.model.expr, tuple(sorted(j.law.params.items())), j.radius_m, j.stations)
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
        """Complex phasors (H+1, n_rows) of x mapped by ``rows`` (default: the outputs)."""
        rows = self.sys.outputs if rows is None else rows
        Y = x.reshape(self.m, self.sys.n) @ np.atleast_2d(rows).T
        out = np.empty((self.H + 1, Y.shape[1]), complex)
        out[0] = Y[0]
        out[1:] = Y[1::2] - 1j * Y[2::2]
        return out
