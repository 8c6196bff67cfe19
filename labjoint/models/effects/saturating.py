"""A saturating (non-hysteretic) elastic law: saturating_stiffness.

Law (memoryless, odd, conservative), u the relative displacement from rest:

    F = k_s x_s tanh(u / x_s)                                                  (S1)

k_s (N/m, any sign) is the stiffness the law adds at |u| << x_s; beyond x_s (m, > 0) its
force levels off at k_s x_s. Beside a linear_stiffness k the joint is k + k_s at small
amplitude and k at large: k_s > 0 a softening from k + k_s to k, k_s < 0 a stiffening from
k - |k_s| to k. Physically the elastic part of micro-slip without its loss (asperities of
a rough interface that bend elastically and then carry no more), or a compliant layer
that saturates. Unlike a cubic spring, whose change of stiffness grows without bound
(k + 3/4 k3 U^2), the change is bounded by |k_s|; unlike a slip law (coulomb, iwan) it
opens no loop.

Describing function (first harmonic of F for u = U sin wt, per unit U):

    k_eq(U) = k + k_s D(U / x_s),
    D(a) = (2 / (pi a)) int_0^pi tanh(a sin t) sin t dt                        (S2)

D(0) = 1 (D(a) = 1 - a^2 / 4 + O(a^4)), D(a) ~ 4 / (pi a) for a >> 1 (the force a
square wave of height k_s x_s). The force is odd and single-valued: zero energy per
cycle, odd harmonics only. For |u| << x_s, (S1) is k_s u - k_s u^3 / (3 x_s^2): a linear
plus a cubic stiffness, so amplitudes well beyond x_s are what tell the two apart.

Starting values (:meth:`SaturatingStiffness.guess`): with three or more runs of distinct
amplitude, least squares of their equivalent stiffnesses k_eq(U_i) on (1, D(U_i / x_s))
over a grid of x_s (:func:`keq_fit`), if its x_s lies inside the grid and |k_s| within
the measured stiffnesses; else the largest run's own least squares of the force
on (u, v, 1, x_s tanh(u / x_s)) over a grid of x_s
(:func:`labjoint.models.summary.saturation_terms`). Never from zero.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from labjoint.models.effects import _steady
from labjoint.models.effects.base import ElasticEffect
from labjoint.models.summary import LoopSummary

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(200)
#: quadrature of (S2) over t in (0, pi / 2) (the integrand is symmetric about pi / 2)
_T = 0.25 * np.pi * (_NODES + 1.0)
_W = 0.25 * np.pi * _WEIGHTS
_SIN = np.sin(_T)
#: grid of x_s as fractions of the amplitude range for :func:`keq_fit`
KEQ_GRID = 60


def describing(a: np.ndarray | float) -> np.ndarray:
    """D(a) of (S2) (array in, array out): 1 - a^2 / 4 below a = 1e-3, Gauss-Legendre
    quadrature (200 nodes on half the period) above."""
    a = np.abs(np.asarray(a, dtype=float))
    out = np.empty_like(a)
    small = a < 1e-3
    out[small] = 1.0 - a[small] ** 2 / 4.0
    big = a[~small]
    if big.size:
        integ = 2.0 * (np.tanh(np.multiply.outer(big, _SIN)) * _SIN) @ _W
        out[~small] = 2.0 / (np.pi * big) * integ
    return out


def keq_fit(U: Sequence[float], k_eq: Sequence[float]) -> tuple[float, float, float] | None:
    """(k, k_s, x_s) of least squares k_eq(U_i) = k + k_s D(U_i / x_s): the best of a grid
    of x_s from U_min / 10 to 10 U_max (log spaced), refined between its neighbours
    (bounded scalar search in log x_s); None with fewer than three distinct amplitudes."""
    U, K = np.asarray(U, float), np.asarray(k_eq, float)
    ok = np.isfinite(U) & np.isfinite(K) & (U > 0)
    U, K = U[ok], K[ok]
    if np.unique(np.round(np.log(U), 3)).size < 3:
        return None

    def solve(log_xs: float) -> tuple[float, float, float]:
        A = np.column_stack([np.ones_like(U), describing(U / np.exp(log_xs))])
        th, *_ = np.linalg.lstsq(A, K, rcond=None)
        r = K - A @ th
        return float(r @ r), float(th[0]), float(th[1])

    grid = np.linspace(np.log(U.min() / 10), np.log(10 * U.max()), KEQ_GRID)
    i = int(np.argmin([solve(g)[0] for g in grid]))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    x = float(minimize_scalar(lambda g: solve(g)[0], bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-4}).x)
    _, k, ks = solve(x)
    return k, ks, float(np.exp(x))


class SaturatingStiffness(ElasticEffect):
    """F = k_s x_s tanh(u / x_s) (S1)."""

    name = "saturating_stiffness"
    needs_multistart = True
    log_params = frozenset({"x_s"})
    description = (
        "An elastic stiffness that saturates: F = k_s x_s tanh(u / x_s) adds k_s at "
        "displacements well below x_s and a constant force k_s x_s beyond, so the joint "
        "softens from k + k_s to k (k_s > 0; k_s < 0 stiffens) and levels off: the elastic "
        "part of micro-slip without its loss (asperities of a rough interface that bend "
        "and then carry no more), a compliant layer that saturates. Conservative: no loop "
        "opens.")
    signature = (
        "Equivalent stiffness k + k_s D(U / x_s) that changes by at most |k_s| and levels "
        "off beyond x_s (D = 1 at small amplitude, ~ 4 x_s / (pi U) at large), no extra "
        "loss per cycle, odd harmonics only (a 3rd harmonic strongest near U ~ x_s that "
        "does not keep growing with amplitude, unlike a cubic spring's).")

    def elastic(self, params: Mapping[str, float], u: np.ndarray) -> np.ndarray:
        k, xs = float(params["k_s"]), float(params["x_s"])
        u = np.asarray(u, dtype=float)
        if not xs > 0:
            return np.zeros_like(u)     # the law's limit as x_s -> 0
        return k * xs * np.tanh(u / xs)

    def steady_term(self, params: Mapping[str, float]) -> tuple[int, np.ndarray]:
        return _steady.SATURATING, np.array([float(params["k_s"]), float(params["x_s"])])

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        U = [r.U for r in summary.runs]
        keq = [r.k_eq for r in summary.runs]
        fit = keq_fit(U, keq)
        # taken when it is a law the loops can hold: x_s inside the grid (not at an end)
        # and |k_s| within the stiffnesses measured (records with a mass give k - m w^2)
        if fit is not None and fit[1] != 0.0 and 0.11 * min(U) < fit[2] < 9.0 * max(U) \
                and abs(fit[1]) <= max(abs(k) for k in keq):
            return {"k_s": fit[1], "x_s": fit[2]}
        r = summary.largest
        xs = r.sat_x if r.sat_x > 0 else 0.3 * r.U
        ks = r.sat_k if r.sat_k != 0 else 0.1 * r.k_eq
        return {"k_s": float(ks), "x_s": float(xs)}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"k_s": max(abs(guess["k_s"]), 0.1 * abs(summary.largest.k_eq), 1e-300),
                "x_s": max(guess["x_s"], 1e-300)}
