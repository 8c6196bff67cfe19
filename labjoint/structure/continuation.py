"""Pseudo-arc-length continuation of harmonic-balance solutions in frequency.

Unknowns y = (x / x_ref, w / w_ref), x_ref the largest linearised response in the band
and w_ref the band's start (so both parts are of order one along the whole curve). From a
converged point the predictor steps ``ds`` along the unit tangent t (null vector of
[dR/dx, dR/dw], oriented like the previous one, so the path turns at folds and
follows the jump branches of a softening joint, seed 000 Fig. 7); the corrector solves
R(y) = 0 with t . (y - y_pred) = 0 by Newton. The step grows after easy corrections and
shrinks after hard ones; a failed correction halves it. When the step falls below
``ds_min`` the continuation stops with a :class:`ConvergenceError` stating the frequency,
the amplitude reached and the residual: a partial curve is never returned as a result.
The last point is placed on the band's end by a fixed-frequency solve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from labjoint.errors import InputError
from labjoint.structure.hbm import ConvergenceError, HarmonicBalance

CORRECTOR_MAX = 12
TOL = 1e-7          # the AFT residual with finite-difference Jacobians stalls near 1e-8 at resonance


@dataclass(frozen=True)
class Curve:
    """Solutions along a frequency band: frequencies (P,), unknowns (P, (2H+1) n), and the
    sign of dw/ds at each point (-1 between two folds: the unstable middle branch)."""

    frequencies_hz: np.ndarray
    x: np.ndarray
    direction: np.ndarray
    force_n: float
    hbm: HarmonicBalance

    def phasors(self, rows: np.ndarray | None = None) -> np.ndarray:
        """(P, H+1, n_rows) complex phasors (default rows: the system's outputs)."""
        return np.array([self.hbm.phasors(x, rows) for x in self.x])

    @property
    def turning_points_hz(self) -> list[float]:
        d = self.direction
        return [float(self.frequencies_hz[i]) for i in np.flatnonzero(d[1:] != d[:-1])]


def continuation(hbm: HarmonicBalance, force_n: float, f_start_hz: float, f_end_hz: float,
                 ds: float = 0.01, ds_min: float = 1e-7, ds_max: float = 0.05,
                 max_points: int = 5000) -> Curve:
    """The response curve from ``f_start_hz`` to ``f_end_hz`` at force amplitude ``force_n``."""
    if not (np.isfinite(f_start_hz) and np.isfinite(f_end_hz) and 0 < f_start_hz < f_end_hz):
        raise InputError(f"band must be 0 < start < end, got {f_start_hz}:{f_end_hz} Hz", field="band")
    if not (np.isfinite(force_n) and force_n > 0):
        raise InputError(f"force amplitude must be > 0 N, got {force_n}", field="force_n")
    w0, w1 = 2 * np.pi * f_start_hz, 2 * np.pi * f_end_hz
    x = hbm.solve(w0, force_n)
    probe = np.linspace(w0, w1, 64)
    xr = max(max(np.linalg.norm(hbm.linear_solution(w, force_n)) for w in probe), 1e-300)
    wr = w0
    scale = max(np.linalg.norm(hbm.external(force_n)), 1e-300)

    def aug_jac(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xx, w = y[:-1] * xr, y[-1] * wr
        R, J = hbm.residual(xx, w, force_n, jacobian=True)
        Jw = hbm.d_dw(xx, w, force_n)
        return R / scale, np.hstack([J * xr, (Jw * wr)[:, None]]) / scale

    def tangent(A: np.ndarray, prev: np.ndarray) -> np.ndarray:
        t = np.linalg.solve(np.vstack([A, prev[None, :]]), np.r_[np.zeros(A.shape[0]), 1.0])
        return t / np.linalg.norm(t)

    y = np.r_[x / xr, 1.0]
    R, A = aug_jac(y)
    t = tangent(A, np.r_[np.zeros(x.size), 1.0])
    pts, dirs = [y.copy()], [1]
    while True:
        if len(pts) > max_points:
            raise ConvergenceError(f"continuation exceeded {max_points} points at "
                                   f"{y[-1] * wr / (2 * np.pi):.6g} Hz without reaching {f_end_hz:g} Hz")
        ok = False
        while not ok:
            yp = y + ds * t
            yn, ok, its, res = _correct(aug_jac, yp, t)
            if not ok:
                ds /= 2
                if ds < ds_min:
                    raise ConvergenceError(
                        f"continuation stopped at {y[-1] * wr / (2 * np.pi):.6g} Hz (response norm "
                        f"{np.linalg.norm(y[:-1]) * xr:.3g}): the corrector did not converge (relative "
                        f"residual {res:.3g} after {its} iterations) even with the smallest step "
                        f"{ds_min:g}; the path may end or branch here")
        if yn[-1] * wr >= w1:                                 # past the band's end
            xe = hbm.solve(w1, force_n, x0=_interp_end(y, yn, w1 / wr) * xr)
            pts.append(np.r_[xe / xr, w1 / wr])
            dirs.append(1)
            break
        if yn[-1] * wr < w0 * (1 - 1e-9) and len(pts) > 2:
            raise ConvergenceError(f"continuation turned back below the band's start ({f_start_hz:g} Hz) "
                                   f"at {yn[-1] * wr / (2 * np.pi):.6g} Hz; widen the band")
        R, A = aug_jac(yn)
        t = tangent(A, t)
        y = yn
        pts.append(y.copy())
        dirs.append(1 if t[-1] >= 0 else -1)
        ds = min(ds * 1.5, ds_max) if its <= 3 else (ds * 0.7 if its > 6 else ds)
    P = np.array(pts)
    return Curve(P[:, -1] * wr / (2 * np.pi), P[:, :-1] * xr, np.array(dirs), float(force_n), hbm)


def _correct(aug_jac, yp: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, bool, int, float]:
    y = yp.copy()
    res = np.inf
    for it in range(1, CORRECTOR_MAX + 1):
        R, A = aug_jac(y)
        res = float(np.linalg.norm(R))
        G = np.r_[R, t @ (y - yp)]
        if res < TOL and abs(G[-1]) < 1e-12:
            return y, True, it, res
        dy = lu_solve(lu_factor(np.vstack([A, t[None, :]])), -G)
        y = y + dy
        if not np.all(np.isfinite(y)):
            return y, False, it, res
        if np.linalg.norm(dy) < 1e-12 * max(1.0, np.linalg.norm(y)) and res < 1e3 * TOL:
            return y, True, it, res
    return y, False, CORRECTOR_MAX, res


def _interp_end(y0: np.ndarray, y1: np.ndarray, w_end: float) -> np.ndarray:
    a = (w_end - y0[-1]) / (y1[-1] - y0[-1])
    return (1 - a) * y0[:-1] + a * y1[:-1]
