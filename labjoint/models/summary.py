"""Simple loop quantities of measured runs, the source of every effect's initial guess.

Per run, over its steady samples: displacement and force amplitudes (half the
0.1-99.9 percentile range), dissipated energy per cycle (the loop area, sum of F v / fs
divided by the number of cycles), equivalent stiffness and damping (least squares
F ~ k u + c v + F0, the first-harmonic fit), the stick slope just after reversals and
the tip slope just before them (straight-line fits over the first / last 10 % of each
branch's travel), the per-cycle energies (wear) and the mean-force asymmetry; for the even
(asymmetric) elastic effects, least squares of F on (u, v, 1) and one even term: u^2
(``k2``), the two sides' slopes max(u, 0), min(u, 0) (``k_plus``, ``k_minus``), and a
one-sided contact max(s u - g, 0) on the stiffer side s over a grid of gaps g from 0 to
0.8 of that side's reach (``contact_k`` signed by the side, ``contact_gap``: the gap of
least residual); for the saturating stiffness, least squares of F on (u, v, 1,
x_s tanh(u / x_s)) over a grid of x_s from 0.02 to 3 times the amplitude (``sat_k``,
``sat_x``: the x_s of least residual, :func:`saturation_terms`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from labjoint.errors import InputError
from labjoint.models.inputs import RunData, shift

BRANCH_FRACTION = 0.1


def _mean_finite(*xs: float) -> float:
    ok = [x for x in xs if np.isfinite(x)]
    return float(np.mean(ok)) if ok else float("nan")


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    if x.size < 3 or np.ptp(x) == 0:
        return float("nan")
    return float(np.polyfit(x, y, 1)[0])


@dataclass(frozen=True)
class RunLoop:
    """Loop quantities of one run (SI units; energies in J per cycle)."""

    name: str
    frequency_hz: float
    U: float
    Fa: float
    u_mean: float
    F_mean: float
    f_max: float
    f_min: float
    energy: float
    k_eq: float
    c_eq: float
    k_stick: float
    k_tip: float
    cycle_energy: np.ndarray
    k2: float = 0.0
    k_plus: float = float("nan")
    k_minus: float = float("nan")
    contact_k: float = 0.0
    contact_gap: float = 0.0
    sat_k: float = 0.0
    sat_x: float = 0.0

    @property
    def asymmetry(self) -> float:
        """(F_max + F_min) / (F_max - F_min) relative to the mean-force-free loop."""
        span = self.f_max - self.f_min
        return 0.0 if span <= 0 else float((self.f_max + self.f_min) / span)


CONTACT_GAPS = np.linspace(0.0, 0.8, 9)
#: x_s / U tried by :func:`saturation_terms`
SAT_WIDTHS = np.geomspace(0.02, 3.0, 12)


def _lsq(cols: list[np.ndarray], f: np.ndarray) -> tuple[np.ndarray, float]:
    """Least squares of f on the columns (normal equations of the scaled columns; einsum,
    not a threaded BLAS): (coefficients, residual sum of squares)."""
    A = np.column_stack(cols)
    n = np.sqrt(np.einsum("ij,ij->j", A, A))
    n[n == 0] = 1.0
    As = A / n
    th = np.linalg.lstsq(np.einsum("ij,ik->jk", As, As), np.einsum("ij,i->j", As, f),
                         rcond=1e-12)[0]
    r = f - As @ th
    return th / n, float(r @ r)


def even_terms(u: np.ndarray, v: np.ndarray, f: np.ndarray) -> dict[str, float]:
    """The even effects' least-squares terms of one run (module docstring)."""
    one = np.ones_like(u)
    k2 = float(_lsq([u, u * u, v, one], f)[0][1])
    th, _ = _lsq([np.maximum(u, 0.0), np.minimum(u, 0.0), v, one], f)
    k_plus, k_minus = float(th[0]), float(th[1])
    side = 1.0 if k_plus >= k_minus else -1.0
    reach = float(np.max(side * u))
    best = (np.inf, 0.0, 0.0)
    if reach > 0:
        for frac in CONTACT_GAPS:
            g = frac * reach
            th, ssr = _lsq([u, v, one, np.maximum(side * u - g, 0.0)], f)
            if ssr < best[0]:
                best = (ssr, side * abs(float(th[3])), g)
    return {"k2": k2, "k_plus": k_plus, "k_minus": k_minus, "contact_k": best[1],
            "contact_gap": best[2]}


def saturation_terms(u: np.ndarray, v: np.ndarray, f: np.ndarray, U: float) -> dict[str, float]:
    """The saturating stiffness's least-squares terms of one run of amplitude ``U``
    (module docstring): {"sat_k": k_s, "sat_x": x_s}."""
    one = np.ones_like(u)
    best = (np.inf, 0.0, 0.0)
    for w in SAT_WIDTHS:
        xs = w * U
        th, ssr = _lsq([u, v, one, xs * np.tanh(u / xs)], f)
        if ssr < best[0]:
            best = (ssr, float(th[3]), xs)
    return {"sat_k": best[1], "sat_x": best[2]}


def run_loop(run: RunData) -> RunLoop:
    """Loop quantities of ``run`` over its steady samples."""
    m = run.steady
    inp = run.inputs
    u, v, f = inp.u[m], inp.v[m], run.force[m]
    fs = inp.fs
    freq = run.frequency_hz
    lo, hi = np.percentile(u, [0.1, 99.9])
    flo, fhi = np.percentile(f, [0.1, 99.9])
    U = 0.5 * (hi - lo)
    if U <= 0:
        raise InputError(f"run '{run.name}': displacement does not move on steady samples",
                         field="displacement")
    n_cyc = max(m.sum() * freq / fs, 1e-9)
    energy = float(np.sum(f * v) / fs / n_cyc)
    A = np.column_stack([u, v, np.ones_like(u)])
    k_eq, c_eq, _ = np.linalg.lstsq(A, f, rcond=None)[0]
    travel = 2 * U
    up, dn = v > 0, v < 0
    near_lo, near_hi = u < lo + BRANCH_FRACTION * travel, u > hi - BRANCH_FRACTION * travel
    stick = _mean_finite(_slope(u[up & near_lo], f[up & near_lo]), _slope(u[dn & near_hi], f[dn & near_hi]))
    tip = _mean_finite(_slope(u[up & near_hi], f[up & near_hi]), _slope(u[dn & near_lo], f[dn & near_lo]))
    # per-cycle energies over the steady samples (chunks of one period)
    idx = np.flatnonzero(m)
    per = fs / freq
    cyc = np.floor((idx - idx[0]) / per).astype(int)
    pw = run.force[idx] * inp.v[idx] / fs
    n_full = int(cyc.max())  # the last chunk may be partial: drop it
    cycle_energy = np.bincount(cyc, weights=pw)[:n_full] if n_full > 0 else np.array([energy])
    return RunLoop(run.name, float(freq), float(U), float(0.5 * (fhi - flo)), float(np.mean(u)),
                   float(np.mean(f)), float(fhi), float(flo), energy, float(k_eq), float(c_eq),
                   float(stick), float(tip), cycle_energy, **even_terms(u, v, f),
                   **saturation_terms(u, v, f, float(U)))


@dataclass(frozen=True)
class LoopSummary:
    """Loop quantities of a set of runs and the aggregates the guesses use."""

    runs: tuple[RunLoop, ...]

    @classmethod
    def from_runs(cls, runs: Sequence[RunData]) -> LoopSummary:
        if not runs:
            raise InputError("no runs given", field="runs")
        return cls(tuple(run_loop(r) for r in runs))

    @property
    def largest(self) -> RunLoop:
        return max(self.runs, key=lambda r: r.U)

    @property
    def smallest(self) -> RunLoop:
        return min(self.runs, key=lambda r: r.U)

    @property
    def k_eq(self) -> float:
        """Equivalent (secant) stiffness at the smallest amplitude (N/m)."""
        return self.smallest.k_eq

    @property
    def k_stick(self) -> float:
        """Stick stiffness: slope after reversal at the smallest amplitude, >= k_eq (N/m)."""
        r = self.smallest
        k = r.k_stick if np.isfinite(r.k_stick) and r.k_stick > 0 else r.k_eq
        return float(max(k, abs(r.k_eq), 1e-12))

    @property
    def k_tip(self) -> float:
        """Slope before reversal at the largest amplitude (N/m, >= 0)."""
        k = self.largest.k_tip
        return float(max(k, 0.0)) if np.isfinite(k) else 0.0

    @property
    def c_eq(self) -> float:
        """Equivalent viscous damping, median over runs (N s/m, >= 0)."""
        return float(max(np.median([r.c_eq for r in self.runs]), 0.0))

    @property
    def energy_exponent(self) -> float:
        """Slope of log(energy per cycle) against log(amplitude); 2 if undetermined."""
        U = np.array([r.U for r in self.runs])
        E = np.array([r.energy for r in self.runs])
        ok = E > 0
        if ok.sum() < 2 or np.ptp(np.log(U[ok])) < 0.05:
            return 2.0
        return float(np.polyfit(np.log(U[ok]), np.log(E[ok]), 1)[0])

    def jenkins_strength(self, k: float) -> float:
        """Slip force f_s of a Jenkins element of stiffness k dissipating the largest run's
        loop: 4 f_s (U - f_s / k) = E, smaller root (k U / 2 if none), kept within
        [0.02, 1] x the force amplitude (N)."""
        r = self.largest
        disc = (k * r.U) ** 2 - k * max(r.energy, 0.0)
        fs = 0.5 * k * r.U if disc <= 0 else 0.5 * (k * r.U - np.sqrt(disc))
        return float(np.clip(fs, 0.02 * r.Fa, r.Fa))

    @property
    def energy_scale(self) -> float:
        """Largest friction energy the data could hold: sum of 4 Fa U per steady cycle (J)."""
        return float(sum(4 * r.Fa * r.U * max(r.cycle_energy.size, 1) for r in self.runs))


def period_shift_floor(runs: Sequence[RunData]) -> float:
    """A quick noise-floor NRMSE of periodic runs, where the fitter's multi-start stops
    when no caller gives one (the comparison's stated estimates are in
    :mod:`labjoint.compare`), pooled over the steady samples: the force is compared with
    itself one period later (4-point cubic shift by
    the fractional period); for white noise of variance s^2 the difference has variance
    s^2 (1 + sum w_k^2), w_k the interpolation weights."""
    num = den = 0.0
    for r in runs:
        idx = np.flatnonzero(r.steady)
        a, b = int(idx[0]), int(idx[-1]) + 1
        f = r.force[a:b]
        per = r.inputs.fs / r.frequency_hz
        n_ok = f.size - int(np.ceil(per)) - 2
        if n_ok < 8:
            continue
        d = f[:n_ok] - shift(f, -per)[:n_ok]
        mu = per - np.floor(per)
        w = np.array([-mu * (mu - 1) * (mu - 2) / 6, (mu + 1) * (mu - 1) * (mu - 2) / 2,
                      -(mu + 1) * mu * (mu - 2) / 2, (mu + 1) * mu * (mu - 1) / 6])
        var = float(np.mean(d * d)) / (1.0 + float(w @ w))
        num += var * idx.size
        den += float(r.force[idx] @ r.force[idx])
    return float(np.sqrt(num / den)) if den > 0 else float("nan")
