"""Time integration of the nonlinear system with the elements' hysteretic state (Newmark).

Average-acceleration Newmark (gamma = 1/2, beta = 1/4: unconditionally stable, no
numerical damping). The linear part is factorised once; each step is condensed onto the
element coordinates q = S x: q = q_lin - G g(q), G = S K_eff^-1 S^T, solved by Newton
with a finite-difference tangent of each law along its history (for one element,
Brent's method on the bracket [q_lin, q_lin - G g(q_lin)] if Newton stalls; a law that
is monotone along a step has exactly one root there). Each element's past is kept as
its reversal points (:mod:`labjoint.structure.law`), exact for rate-independent laws.

:func:`steady_state` repeats periods of F cos(w t) from rest until the response over one
period changes by less than ``tol`` of its range, and returns that period's harmonics
in the phasor convention of :mod:`labjoint.structure.hbm`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import lu_factor, lu_solve
from scipy.optimize import brentq

from labjoint.errors import InputError
from labjoint.structure.hbm import ConvergenceError
from labjoint.structure.law import push_reversal
from labjoint.structure.system import NonlinearSystem

GAMMA, BETA = 0.5, 0.25
NEWTON_MAX = 30


@dataclass(frozen=True)
class SteadyState:
    """One steady period: outputs (n_out, N) and their phasors (H+1, n_out)."""

    frequency_hz: float
    periods: int
    outputs: np.ndarray
    phasors: np.ndarray


class Newmark:
    """Fixed-step integrator of a :class:`NonlinearSystem` under a force history."""

    def __init__(self, system: NonlinearSystem, dt: float) -> None:
        if not (np.isfinite(dt) and dt > 0):
            raise InputError(f"time step must be > 0 s, got {dt}", field="dt")
        for e in system.elements:
            law = getattr(e, "law", None) or e.joint.law
            law.check_steppable()
        self.sys, self.dt = system, dt
        self.a1, self.a2, self.a3 = 1 / (BETA * dt * dt), 1 / (BETA * dt), 1 / (2 * BETA) - 1
        self.a4, self.a5, self.a6 = GAMMA / (BETA * dt), GAMMA / BETA - 1, dt * (GAMMA / (2 * BETA) - 1)
        Keff = system.K + self.a4 * system.C + self.a1 * system.M
        self.lu = lu_factor(Keff)
        S = system.selectors
        self.W = lu_solve(self.lu, S.T)                     # K_eff^-1 S^T (n, n_e)
        self.G = S @ self.W
        self.x = np.zeros(system.n)
        self.v = np.zeros(system.n)
        self.a = np.zeros(system.n)
        self.rev = [[0.0] for _ in system.elements]
        self.g = np.zeros(len(system.elements))

    def start(self, f0: float) -> None:
        """At rest; initial acceleration from the force at t = 0."""
        self.a = np.linalg.solve(self.sys.M, f0 * self.sys.force)

    def _forces(self, q: np.ndarray, qn: np.ndarray, qdn: np.ndarray, qddn: np.ndarray) -> np.ndarray:
        qdd = self.a1 * (q - qn) - self.a2 * qdn - self.a3 * qddn
        qd = qdn + self.dt * ((1 - GAMMA) * qddn + GAMMA * qdd)
        return np.array([e.step(np.asarray(r), qi, vi, ai)
                         for e, r, qi, vi, ai in zip(self.sys.elements, self.rev, q, qd, qdd)])

    def step(self, f1: float) -> None:
        s, x, v, a = self.sys, self.x, self.v, self.a
        rhs = f1 * s.force + s.M @ (self.a1 * x + self.a2 * v + self.a3 * a) \
            + s.C @ (self.a4 * x + self.a5 * v + self.a6 * a)
        xl = lu_solve(self.lu, rhs)
        S = s.selectors
        ql, qn, qdn, qddn = S @ xl, S @ x, S @ v, S @ a
        q = self._solve(ql, qn, qdn, qddn)
        g = self._forces(q, qn, qdn, qddn)
        xn = xl - self.W @ g
        an = self.a1 * (xn - x) - self.a2 * v - self.a3 * a
        self.v = v + self.dt * ((1 - GAMMA) * a + GAMMA * an)
        self.x, self.a, self.g = xn, an, g
        for r, qi in zip(self.rev, S @ xn):
            push_reversal(r, float(qi))

    def _solve(self, ql, qn, qdn, qddn) -> np.ndarray:
        def h(q):
            return q - ql + self.G @ self._forces(q, qn, qdn, qddn)
        q = qn.copy() if qn.size else qn
        r = h(q)
        scale = max(np.max(np.abs(ql - qn)), np.max(np.abs(qn)), 1e-30)
        for _ in range(NEWTON_MAX):
            if np.max(np.abs(r)) <= 1e-12 * scale:
                return q
            d = 1e-7 * scale
            J = np.column_stack([(h(q + d * np.eye(q.size)[i]) - r) / d for i in range(q.size)])
            try:
                q = q - np.linalg.solve(J, r)
            except np.linalg.LinAlgError:
                break
            r = h(q)
        if np.max(np.abs(r)) <= 1e-9 * scale:
            return q
        if q.size == 1:
            g0 = self._forces(ql, qn, qdn, qddn)
            b = ql - self.G @ g0
            if b[0] == ql[0]:
                return ql
            return np.array([brentq(lambda z: h(np.array([z]))[0], min(ql[0], b[0]), max(ql[0], b[0]),
                                    xtol=1e-14 * scale)])
        raise ConvergenceError(f"time step did not converge (residual {np.max(np.abs(r)):.3g})")


def steady_state(system: NonlinearSystem, force_n: float, frequency_hz: float, harmonics: int = 5,
                 steps_per_period: int = 512, max_periods: int = 2000, tol: float = 1e-6) -> SteadyState:
    """Integrate F cos(w t) from rest to the periodic steady state (module docstring)."""
    w = 2 * np.pi * frequency_hz
    n = int(steps_per_period)
    nm = Newmark(system, 2 * np.pi / w / n)
    nm.start(force_n)
    phase = 2 * np.pi * np.arange(1, n + 1) / n
    fcos = force_n * np.cos(phase)
    prev = None
    for p in range(1, max_periods + 1):
        out = np.empty((system.outputs.shape[0], n))
        for i in range(n):
            nm.step(fcos[i])
            out[:, i] = system.outputs @ nm.x
        if prev is not None and np.max(np.abs(out - prev)) <= tol * max(np.ptp(out), 1e-300):
            break
        prev = out
    else:
        raise ConvergenceError(f"no steady state at {frequency_hz:g} Hz within {max_periods} periods")
    # samples at phase 2 pi (i + 1) / n: rotate so sample j is at phase 2 pi j / n
    y = np.roll(out, 1, axis=1)
    c = np.fft.rfft(y, axis=1) / n
    ph = np.empty((harmonics + 1, y.shape[0]), complex)
    ph[0] = c[:, 0].real
    ph[1:] = 2 * c[:, 1:harmonics + 1].T
    return SteadyState(float(frequency_hz), p, out, ph)
