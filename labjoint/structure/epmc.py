"""Extended periodic motion concept (EPMC, Krack 2015): a nonlinear mode's frequency and
damping against amplitude, by harmonic balance on the structure with its joints.

The autonomous system M x'' + C x' + K x + sum_e s_e^T g_e(s_e x) = 0 has no periodic
motion when the joints dissipate. Krack adds a mass-proportional negative damping
-xi M x' that balances the dissipation exactly over a period:

    M x'' + (C - xi M) x' + K x + sum_e s_e^T g_e(s_e x) = 0,

and solves it by harmonic balance (:class:`~labjoint.structure.hbm.HarmonicBalance`,
AFT for the joints' laws; per harmonic k the extra term is -xi k w M on the off-diagonal
blocks, like C) for the unknowns (X, w, xi) with two more equations fixing amplitude and
phase at the named output (a sensor) ``r``:

    r . X_s1 = 0 (phase: the fundamental is a cosine there),  r . X_c1 = a (amplitude).

w(a) is the natural frequency; the modal damping ratio is zeta(a) = xi / (2 w) (Krack
2015, Eq. 13; for a linear, classically damped mode it is exactly the mode's ratio). The
amplitude is the fundamental's amplitude of displacement at the sensor (m), the same
measure as the measured backbones (:mod:`labjoint.signal.ringdown`, phase resonance).

Continuation: amplitudes ascending, each solved by Newton from the previous solution
scaled to the new amplitude (the first from the linearised mode with the joints stuck,
:meth:`NonlinearSystem.linear_stiffness`). The Jacobian in x is the harmonic balance's
(exact linear part, finite differences for the laws); in w exact for the linear part
(:meth:`HarmonicBalance.d_dw`, finite difference for rate-dependent laws); in xi exact.
A failed solve raises :class:`~labjoint.structure.hbm.ConvergenceError` naming the
amplitude; no partial backbone is returned as a result.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh, lu_factor, lu_solve

from labjoint.errors import InputError
from labjoint.signal.backbone import Backbone, BackbonePoint
from labjoint.structure.hbm import ConvergenceError, HarmonicBalance
from labjoint.structure.system import NonlinearSystem

NEWTON_MAX = 30
TOL = 1e-8


class EPMC:
    """EPMC of mode ``mode`` (0: the first) of ``system`` with ``harmonics`` H."""

    def __init__(self, system: NonlinearSystem, mode: int = 0, harmonics: int = 3,
                 samples: int | None = None, output: str | None = None) -> None:
        self.hb = HarmonicBalance(system, harmonics, samples)
        self.sys = system
        names = list(system.output_names)
        if output is None:
            output = names[-1]
        if output not in names:
            raise InputError(f"no output {output!r}; the system's outputs: {', '.join(names)}",
                             field="sensor")
        self.output = output
        self.r = np.asarray(system.outputs[names.index(output)], float)
        K = system.linear_stiffness()
        lam, phi = eigh(K, system.M)
        if not 0 <= mode < lam.size:
            raise InputError(f"mode must be in 0..{lam.size - 1}, got {mode}", field="mode")
        self.w0 = float(np.sqrt(lam[mode]))
        self.phi = phi[:, mode]
        if abs(self.r @ self.phi) < 1e-9 * np.abs(self.phi).max() * np.abs(self.r).max():
            raise InputError(f"sensor {output!r} sits on a node of mode {mode + 1}: no amplitude "
                             "there to measure the mode by", field="sensor")
        self.zeta0 = float(self.phi @ system.C @ self.phi / (2 * self.w0 * (self.phi @ system.M @ self.phi)))
        n, m = system.n, self.hb.m
        self.n = n
        self._ic1 = slice(n, 2 * n)             # X_c1 rows in the flattened unknowns
        self._is1 = slice(2 * n, 3 * n)
        self._size = m * n

    def _mass_damping(self, w: float) -> np.ndarray:
        """The operator of M x' on the harmonic coefficients (sign: + xi M x')."""
        n, Z = self.n, np.zeros((self._size, self._size))
        M = self.sys.M
        for k in range(1, self.hb.H + 1):
            c, s = slice((2 * k - 1) * n, 2 * k * n), slice(2 * k * n, (2 * k + 1) * n)
            Z[c, s], Z[s, c] = k * w * M, -k * w * M
        return Z

    def _equations(self, y: np.ndarray, a: float) -> tuple[np.ndarray, np.ndarray]:
        x, w, xi = y[:-2], y[-2], y[-1]
        R, J = self.hb.residual(x, w, 0.0, jacobian=True)
        D = self._mass_damping(w)
        R = R - xi * (D @ x)
        J = J - xi * D
        dw = self.hb.d_dw(x, w, 0.0) - xi * (D @ x) / w
        G = np.empty(self._size + 2)
        G[:-2] = R
        G[-2] = self.r @ x[self._is1]
        G[-1] = self.r @ x[self._ic1] - a
        A = np.zeros((self._size + 2, self._size + 2))
        A[:-2, :-2] = J
        A[:-2, -2] = dw
        A[:-2, -1] = -(D @ x)
        A[-2, self._is1] = self.r
        A[-1, self._ic1] = self.r
        return G, A

    def start(self, a: float) -> np.ndarray:
        """The linearised mode at amplitude ``a`` (unknowns y = (x, w, xi))."""
        x = np.zeros(self._size)
        x[self._ic1] = self.phi * a / (self.r @ self.phi)
        return np.r_[x, self.w0, 2 * self.zeta0 * self.w0]

    def solve(self, a: float, y0: np.ndarray) -> np.ndarray:
        """Newton on (X, w, xi) at amplitude ``a`` from ``y0``."""
        y = y0.copy()
        # residual scale: the linear forces of the motion, and the amplitude itself
        K = self.sys.linear_stiffness()
        fscale = max(np.linalg.norm(K @ y[self._ic1]), 1e-300)
        res = np.inf
        for _ in range(NEWTON_MAX):
            G, A = self._equations(y, a)
            res = max(np.linalg.norm(G[:-2]) / fscale, abs(G[-1]) / a, abs(G[-2]) / a)
            if res < TOL:
                return y
            y = y + lu_solve(lu_factor(A), -G)
        if res < 1e2 * TOL:
            return y
        raise ConvergenceError(f"EPMC did not converge at amplitude {a:.4g} m at {self.output} "
                               f"(relative residual {res:.3g} after {NEWTON_MAX} Newton iterations)")

    def backbone(self, amplitudes) -> tuple[Backbone, np.ndarray]:
        """Backbone points at ``amplitudes`` (m at the sensor, ascending) and the
        solutions (P, (2H+1) n + 2)."""
        A = np.asarray(amplitudes, float)
        if A.ndim != 1 or A.size == 0 or not np.all(np.isfinite(A) & (A > 0)):
            raise InputError("amplitudes must be a non-empty list of positive numbers (m)",
                             field="amplitudes")
        order = np.argsort(A)
        sols = np.empty((A.size, self._size + 2))
        y, a_prev = self.start(A[order[0]]), A[order[0]]
        for i in order:
            a = float(A[i])
            y = y.copy()
            y[:-2] *= a / a_prev
            y = self.solve(a, y)
            sols[i], a_prev = y, a
        pts = [BackbonePoint(float(a), float(s[-2] / (2 * np.pi)), float(s[-1] / (2 * s[-2])), "epmc",
                             extra={"xi_per_s": float(s[-1])}) for a, s in zip(A, sols)]
        notes = (f"extended periodic motion concept (Krack 2015), {self.hb.H} harmonics, "
                 f"{self.hb.N} samples per period; amplitude of the fundamental's displacement at "
                 f"{self.output}; linear mode {self.w0 / (2 * np.pi):.6g} Hz, zeta {self.zeta0:.4g}",)
        return Backbone(pts, "m", "displacement", self.output, notes), sols


def epmc_backbone(system: NonlinearSystem, amplitudes, *, mode: int = 0, harmonics: int = 3,
                  samples: int | None = None, sensor: str | None = None) -> Backbone:
    """The EPMC backbone of ``mode`` at ``amplitudes`` (m of displacement at ``sensor``)."""
    return EPMC(system, mode, harmonics, samples, sensor).backbone(amplitudes)[0]
