"""Bouc-Wen hysteretic variable in Wen's classical form (seed 001, Bouc-Wen model).

F = z, dz/dt = A du/dt - alpha |du/dt| |z|^(n-1) z - beta du/dt |z|^n (seed 001), so along
the displacement dz/du = k0 - |z|^n (alpha sgn(z du) + beta) with A = k0. alpha + beta > 0
saturates the loading branch at F_sat = (k0 / (alpha + beta))^(1/n) (softening, the usual
joint); alpha + beta < 0 hardens it (the Bouc-Wen benchmark: alpha = 800, beta = -1100 for
n = 1). Integrated per sample by classical RK4 in u with m = 1 + floor(2 lambda |du|)
substeps, lambda = n |z|^(n-1) (|alpha| + |beta|) the law's stiffness in z at the largest
|z| the step can reach (so lambda h < 0.5, well inside RK4 stability), at most
MAX_SUBSTEPS; a saturating law keeps z within max(|z|, F_sat), a bound of the exact
solution, so a sample spanning hundreds of yield displacements saturates instead of
diverging. Dissipation (for wear): E_d = int z du - z^2 / (2 k0), the plastic work, exact
over closed cycles. Slip modifiers scale the slip strength F_sat by s, that is alpha and
beta by s^-n.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit

from labjoint.models.effects.base import NO_MODIFIERS, HystereticEffect, SlipModifiers
from labjoint.models.summary import LoopSummary

MAX_SUBSTEPS = 256
Z_CAP = 1e12          # N: a hardening law is held finite here (no joint carries this)


@njit(cache=True)
def bw_rate(z, sg_h, k0, al, be, n):  # pragma: no cover - numba
    """dz/du of the classical law; ``sg_h`` carries the sign of du."""
    zh = z * sg_h
    sg = 1.0 if zh > 0.0 else (-1.0 if zh < 0.0 else 0.0)
    return k0 - abs(z) ** n * (al * sg + be)


@njit(cache=True)
def bw_saturation(k0, al, be, n):  # pragma: no cover - numba
    """F_sat = (k0 / (alpha + beta))^(1/n) of a saturating law, else Z_CAP."""
    if al + be > 0.0:
        return (k0 / (al + be)) ** (1.0 / n)
    return Z_CAP


@njit(cache=True)
def bw_bound(z, sat):  # pragma: no cover - numba
    """The largest |z| the exact solution can reach from z: max(|z|, F_sat) for a
    saturating law (``sat`` from :func:`bw_saturation`), else Z_CAP."""
    return min(max(abs(z), sat), Z_CAP) if sat < Z_CAP else Z_CAP


@njit(cache=True)
def bw_step(z, du, k0, al, be, n, sat):  # pragma: no cover - numba
    """z after a displacement step du (RK4 with the module's substep rule)."""
    zmax = bw_bound(z, sat)
    zr = min(abs(z) + k0 * abs(du), zmax)
    lam = n * (abs(al) + abs(be)) * max(zr, 1e-300) ** (n - 1.0)
    m = 1 + int(min(2.0 * lam * abs(du), MAX_SUBSTEPS - 1.0))
    h = du / m
    for _ in range(m):
        k1 = bw_rate(z, h, k0, al, be, n)
        k2 = bw_rate(z + 0.5 * h * k1, h, k0, al, be, n)
        k3 = bw_rate(z + 0.5 * h * k2, h, k0, al, be, n)
        k4 = bw_rate(z + h * k3, h, k0, al, be, n)
        z += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        z = min(max(z, -zmax), zmax)
    return z


@njit(cache=True)
def bouc_wen_force(u, k0, al0, be0, n, asym, inv_ew, e_other):  # pragma: no cover - numba
    """z (N) and cumulative plastic work (J) along ``u``, relaxed at u[0]."""
    m_out = u.size
    out = np.empty(m_out)
    ed_out = np.empty(m_out)
    z = 0.0
    work = 0.0
    ed = 0.0
    out[0] = 0.0
    ed_out[0] = 0.0
    f_last = np.nan                  # the slip scaling of the last step, and its F_sat
    sat = Z_CAP
    for i in range(1, m_out):
        du = u[i] - u[i - 1]
        if du == 0.0:
            out[i] = z
            ed_out[i] = ed
            continue
        s = 1.0
        if inv_ew != 0.0:
            s = np.exp(-(ed + e_other[i - 1]) * inv_ew)
        s *= (1.0 + asym) if du > 0.0 else (1.0 - asym)
        f = 1.0 if s == 1.0 else s ** (-n)          # pow(1, y) is 1: the same number
        if f != f_last:                              # F_sat only changes with f
            sat = bw_saturation(k0, al0 * f, be0 * f, n)
            f_last = f
        z_old = z
        z = bw_step(z, du, k0, al0 * f, be0 * f, n, sat)
        work += 0.5 * (z_old + z) * du
        ed = work - z * z / (2.0 * k0)
        out[i] = z
        ed_out[i] = ed
    return out, ed_out


class BoucWen(HystereticEffect):
    """Smooth hysteresis of initial stiffness k0, softening or hardening with |z|^n."""

    name = "bouc_wen"
    log_params = frozenset({"k0"})
    description = (
        "A phenomenological smooth hysteresis (Bouc 1967, Wen 1976; seed 001): an internal "
        "force z grows with stiffness k0 after each reversal and bends over smoothly, the "
        "sharpness set by n; alpha + beta > 0 saturates it at (k0 / (alpha + beta))^(1/n), "
        "alpha + beta < 0 hardens it, and alpha sets how unloading differs from loading. It "
        "describes gradual stick-to-slip transitions without a slider population.")
    signature = (
        "Rounded loop; with alpha + beta > 0 it saturates and stiffness softens with "
        "amplitude, dissipation growing from ~U^(n+1)-like at small amplitude to linear once "
        "saturated; odd harmonics; independent of frequency; alpha != beta makes unloading "
        "differ from a Masing branch.")

    def simulate(self, params: Mapping[str, float], u: np.ndarray,
                 modifiers: SlipModifiers = NO_MODIFIERS,
                 e_other: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        k0 = float(params["k0"])
        if k0 <= 0:
            return np.zeros_like(u), np.zeros_like(u)
        e = np.zeros_like(u) if e_other is None else e_other
        return bouc_wen_force(u, k0, float(params["alpha"]), float(params["beta"]),
                              float(params["n"]), modifiers.asym, modifiers.inv_ew, e)

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        k0 = summary.k_stick
        n = 2.0
        half = 0.5 * k0 / summary.jenkins_strength(k0) ** n      # saturating at the slip force
        return {"k0": k0, "alpha": half, "beta": half, "n": n}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        a = abs(guess["alpha"]) + abs(guess["beta"])
        return {"k0": guess["k0"], "alpha": 0.5 * a, "beta": 0.5 * a, "n": 1.0}
