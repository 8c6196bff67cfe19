"""Bouc-Wen hysteretic variable (seed 001, with A = k0 and a saturation force F_y).

F = z, dz/du = k0 [1 - |z/F_y|^n (beta sgn(z du) + 1 - beta)] (vocabulary law), integrated
per sample by classical RK4 in u with m = 1 + floor(2 k0 n |du| / F_y) substeps (the
linearised step k0 n |du| / F_y stays below 0.5, well inside RK4 stability), at most
MAX_SUBSTEPS; z is kept within max(|z|, F_y), a bound of the exact solution, so a
sample spanning hundreds of yield displacements saturates instead of diverging.
Dissipation (for wear): E_d = int z du - z^2 / (2 k0), the plastic work, exact over
closed cycles. Slip strength = F_y.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit

from labjoint.models.effects.base import NO_MODIFIERS, HystereticEffect, SlipModifiers
from labjoint.models.summary import LoopSummary

MAX_SUBSTEPS = 256


@njit(cache=True)
def _rhs(z, h, k0, fy, beta, n):  # pragma: no cover - numba
    zh = z * h
    sg = 1.0 if zh > 0.0 else (-1.0 if zh < 0.0 else 0.0)
    return k0 * (1.0 - abs(z / fy) ** n * (beta * sg + 1.0 - beta))


@njit(cache=True)
def bouc_wen_force(u, k0, fy0, beta, n, asym, inv_ew, e_other):  # pragma: no cover - numba
    """z (N) and cumulative plastic work (J) along ``u``, relaxed at u[0]."""
    m_out = u.size
    out = np.empty(m_out)
    ed_out = np.empty(m_out)
    z = 0.0
    work = 0.0
    ed = 0.0
    out[0] = 0.0
    ed_out[0] = 0.0
    nn = max(n, 1.0)
    for i in range(1, m_out):
        du = u[i] - u[i - 1]
        if du == 0.0:
            out[i] = z
            ed_out[i] = ed
            continue
        s = 1.0
        if inv_ew != 0.0:
            s = np.exp(-(ed + e_other[i - 1]) * inv_ew)
        fy = fy0 * s * ((1.0 + asym) if du > 0.0 else (1.0 - asym))
        m = min(1 + int(2.0 * k0 * nn * abs(du) / fy), MAX_SUBSTEPS)
        h = du / m
        z_old = z
        zmax = max(abs(z), fy)  # the exact solution never leaves [-zmax, zmax]
        for _ in range(m):
            k1 = _rhs(z, h, k0, fy, beta, n)
            k2 = _rhs(z + 0.5 * h * k1, h, k0, fy, beta, n)
            k3 = _rhs(z + 0.5 * h * k2, h, k0, fy, beta, n)
            k4 = _rhs(z + h * k3, h, k0, fy, beta, n)
            z += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
            z = min(max(z, -zmax), zmax)
        work += 0.5 * (z_old + z) * du
        ed = work - z * z / (2.0 * k0)
        out[i] = z
        ed_out[i] = ed
    return out, ed_out


class BoucWen(HystereticEffect):
    """Smooth hysteresis saturating at F_y, initial stiffness k0."""

    name = "bouc_wen"
    log_params = frozenset({"k0", "F_y"})
    description = (
        "A phenomenological smooth hysteresis (Bouc 1967, Wen 1976; seed 001): an internal "
        "force z grows with stiffness k0 after each reversal and bends over smoothly to a "
        "saturation force F_y, the sharpness set by n and the unloading shape by beta. It "
        "describes gradual stick-to-slip transitions without a slider population.")
    signature = (
        "Rounded loop saturating at +-F_y; stiffness softens with amplitude, dissipation "
        "grows from ~U^(n+1)-like at small amplitude to linear once saturated; odd "
        "harmonics; independent of frequency; beta != 0.5 makes unloading differ from a "
        "Masing branch.")

    def simulate(self, params: Mapping[str, float], u: np.ndarray,
                 modifiers: SlipModifiers = NO_MODIFIERS,
                 e_other: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        k0, fy = float(params["k0"]), float(params["F_y"])
        if k0 <= 0 or fy <= 0:
            return np.zeros_like(u), np.zeros_like(u)
        e = np.zeros_like(u) if e_other is None else e_other
        return bouc_wen_force(u, k0, fy, float(params["beta"]), float(params["n"]),
                              modifiers.asym, modifiers.inv_ew, e)

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        k0 = summary.k_stick
        return {"k0": k0, "F_y": summary.jenkins_strength(k0), "beta": 0.5, "n": 2.0}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"k0": guess["k0"], "F_y": guess["F_y"], "beta": 0.25, "n": 1.0}
