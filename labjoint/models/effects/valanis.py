"""Valanis endochronic model as used by Lenz and Gaul for lap joints (seed 001).

dF/du = E0 [1 + (lam/E0) sgn(du)(Et u - F)] / [1 + kappa (lam/E0) sgn(du)(Et u - F)]
(vocabulary law, u measured from the relaxed first sample), integrated per sample by
RK4 in u with m = 1 + floor(2 lam |du|) substeps (at most MAX_SUBSTEPS; F - Et u is
kept from passing the slip strength, which the exact solution approaches but never
crosses, so over-stiff steps saturate instead of diverging). On a long monotone path F - Et u tends
to the slip strength w* = E0 (E0 - Et) / (lam (E0 - kappa Et)); modifiers scale w* by
replacing lam with lam / s. Dissipation (for wear): int F du - F^2 / (2 E0).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit

from labjoint.models.effects.base import NO_MODIFIERS, HystereticEffect, SlipModifiers
from labjoint.models.summary import LoopSummary

MAX_SUBSTEPS = 256


@njit(cache=True)
def _rhs(f, x, sg, e0, et, lam, kappa):  # pragma: no cover - numba
    r = (lam / e0) * sg * (et * x - f)
    return e0 * (1.0 + r) / (1.0 + kappa * r)


@njit(cache=True)
def valanis_force(u, e0, et, lam0, kappa, asym, inv_ew, e_other):  # pragma: no cover - numba
    """Force (N) and cumulative dissipation (J) along ``u``, relaxed at u[0]."""
    n = u.size
    out = np.empty(n)
    ed_out = np.empty(n)
    f = 0.0
    work = 0.0
    ed = 0.0
    out[0] = 0.0
    ed_out[0] = 0.0
    for i in range(1, n):
        du = u[i] - u[i - 1]
        if du == 0.0:
            out[i] = f
            ed_out[i] = ed
            continue
        s = 1.0
        if inv_ew != 0.0:
            s = np.exp(-(ed + e_other[i - 1]) * inv_ew)
        sg = 1.0 if du > 0.0 else -1.0
        lam = lam0 / (s * ((1.0 + asym) if du > 0.0 else (1.0 - asym)))
        m = min(1 + int(2.0 * lam * abs(du)), MAX_SUBSTEPS)
        # slip strength: F - Et x tends to sg w* on a monotone path and never passes it
        wstar = e0 * (e0 - et) / (lam * (e0 - kappa * et)) if lam > 0.0 else np.inf
        h = du / m
        x = u[i - 1] - u[0]
        f_old = f
        for _ in range(m):
            k1 = _rhs(f, x, sg, e0, et, lam, kappa)
            k2 = _rhs(f + 0.5 * h * k1, x + 0.5 * h, sg, e0, et, lam, kappa)
            k3 = _rhs(f + 0.5 * h * k2, x + 0.5 * h, sg, e0, et, lam, kappa)
            k4 = _rhs(f + h * k3, x + h, sg, e0, et, lam, kappa)
            f += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
            x += h
            if wstar > 0.0 and sg * (f - et * x) > wstar:
                f = et * x + sg * wstar
        work += 0.5 * (f_old + f) * du
        ed = work - f * f / (2.0 * e0)
        out[i] = f
        ed_out[i] = ed
    return out, ed_out


class Valanis(HystereticEffect):
    """Endochronic (no yield surface) hysteresis: slope E0 after reversal, Et in slip."""

    name = "valanis"
    log_params = frozenset({"E0", "lam"})
    description = (
        "Valanis' endochronic plasticity, used by Lenz and Gaul for bolted lap joints "
        "(seed 001): after every reversal the joint is stiff (E0) and softens smoothly, "
        "without a yield point, towards a sliding slope Et; lam sets how fast, kappa the "
        "shape. It obeys the Masing hypothesis approximately and captures micro-slip "
        "softening with residual stiffness.")
    signature = (
        "Loop with slope E0 at each reversal and Et at the tips; stiffness falls from E0 "
        "towards Et and dissipation grows with amplitude, ending linear in amplitude with a "
        "tilted (Et) plateau; odd harmonics; independent of frequency.")

    def simulate(self, params: Mapping[str, float], u: np.ndarray,
                 modifiers: SlipModifiers = NO_MODIFIERS,
                 e_other: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        e0, lam = float(params["E0"]), float(params["lam"])
        if e0 <= 0:
            return np.zeros_like(u), np.zeros_like(u)
        e = np.zeros_like(u) if e_other is None else e_other
        return valanis_force(u, e0, float(params["Et"]), lam, float(params["kappa"]),
                             modifiers.asym, modifiers.inv_ew, e)

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        e0 = summary.k_stick
        et = min(summary.k_tip, 0.5 * e0)
        kappa = 0.5
        w = summary.jenkins_strength(e0 - et)
        lam = e0 * (e0 - et) / (w * (e0 - kappa * et))
        return {"E0": e0, "Et": et, "lam": float(lam), "kappa": kappa}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"E0": guess["E0"], "Et": max(guess["Et"], 0.05 * guess["E0"]),
                "lam": guess["lam"], "kappa": 0.25}
