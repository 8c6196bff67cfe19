"""Richard-Abbott elastic-plastic law (seed 000 Eq. 2, stress -> force, strain -> displacement)
with Masing unloading and reloading.

Backbone g(u) = (ke - kp) u / (1 + |(ke - kp) u / F_y|^n)^(1/n) + kp u; branches
F = F_r + 2 g((u - u_r)/2) from the last reversal, with the extended Masing memory rules
(``_masing``), exact per sample. With a modifier (asymmetric_slip, wear) the law is
simulated as its equivalent Iwan population: unit-stiffness elements slipping at
displacement phi with density -g''(phi) (Iwan 1966), i.e. in r = (ke - kp) phi / F_y
(ke - kp) (n + 1) r^(n-1) (1 + r^n)^(-(2n+1)/n) dr, discretised in geometric bins of
ratio 0.9 on 1e-3 < r < 1e3 (two Gauss sliders each) plus a lump below and a tail lump
above carrying the exact remaining stiffness and strength, in parallel with kp.
Seed 000 constrains kp < ke (Eq. 9); kp > ke gives a stiffening law.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.errors import InputError
from labjoint.models.effects._masing import RICHARD_ABBOTT, masing_force, ra_params, running_work
from labjoint.models.effects._population import backbone_population, population_force
from labjoint.models.effects._steady import LINEAR, MASING_RA
from labjoint.models.effects.base import NO_MODIFIERS, HystereticEffect, SlipModifiers
from labjoint.models.summary import LoopSummary

R_LO, R_HI, R_RATIO = 1e-3, 1e3, 0.9


def ra_backbone(u: np.ndarray, ke: float, kp: float, F_y: float, n: float) -> np.ndarray:
    """Seed 000 Eq. 2 (force form), vectorised: the monotonic loading curve."""
    a = ke - kp
    y = a * np.asarray(u, float)
    return y / (1.0 + np.abs(y / F_y) ** n) ** (1.0 / n) + kp * np.asarray(u, float)


def ra_population(ke: float, kp: float, F_y: float, n: float) -> tuple[np.ndarray, np.ndarray]:
    """Element stiffnesses (N/m) and slip forces (N) equivalent to the Richard-Abbott
    hysteretic part (the parallel spring kp is separate)."""
    a = ke - kp
    if a <= 0:
        raise InputError("the slider population needs kp < ke (seed 000 Eq. 9)",
                         field="richard_abbott.kp")
    phi_y = F_y / a

    def log1p_rn(r: np.ndarray) -> np.ndarray:
        return np.logaddexp(0.0, n * np.log(r))

    def density(phi: np.ndarray) -> np.ndarray:
        r = phi / phi_y
        return (a / phi_y) * (n + 1) * np.exp((n - 1) * np.log(r) - (2 + 1 / n) * log1p_rn(r))

    def h(phi: float) -> float:  # hysteretic part of the backbone
        r = np.array(phi / phi_y)
        return float(a * phi * np.exp(-log1p_rn(r) / n))

    def dh(phi: float) -> float:
        r = np.array(phi / phi_y)
        return float(a * np.exp(-(1 + 1 / n) * log1p_rn(r)))

    nb = int(np.ceil(np.log(R_HI / R_LO) / -np.log(R_RATIO)))
    edges = phi_y * R_LO * (1 / R_RATIO) ** np.arange(nb + 1)
    k, f = backbone_population(density, edges)
    lo, hi = edges[0], edges[-1]
    k_lo, f_lo = a - dh(lo), h(lo) - lo * dh(lo)          # lump below: exact moments
    k_hi = dh(hi)
    f_hi = F_y - (h(hi) - hi * dh(hi))                    # tail: the remaining strength
    return np.concatenate([[k_lo], k, [k_hi]]), np.concatenate([[f_lo], f, [f_hi]])


class RichardAbbott(HystereticEffect):
    """Smooth elastic-plastic backbone (seed 000 Eq. 2) with Masing branches."""

    name = "richard_abbott"
    log_params = frozenset({"ke", "F_y"})
    description = (
        "The constitutive law seed 000 gives its thin layer of joint elements: stiffness ke "
        "while stuck, bending over near the yield force F_y into a sliding slope kp, with "
        "shape factor n from smooth (small n) to bilinear (large n). Unloading and reloading "
        "follow Masing branches (the backbone scaled by two from each reversal), so it "
        "describes stick, micro-slip and the onset of macro-slip with softening.")
    signature = (
        "Stiffness softens with amplitude from ke towards kp, dissipation grows steeply "
        "around U ~ F_y/(ke - kp) then linearly; loop tips keep slope kp; odd harmonics; "
        "independent of frequency.")

    def population(self, params: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray, float]:
        """Equivalent slider population (stiffnesses, slip forces) and the parallel kp."""
        ke, kp = float(params["ke"]), float(params["kp"])
        k, f = ra_population(ke, kp, float(params["F_y"]), float(params["n"]))
        return k, f, kp

    def simulate(self, params: Mapping[str, float], u: np.ndarray,
                 modifiers: SlipModifiers = NO_MODIFIERS,
                 e_other: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        ke, kp, fy, n = (float(params[p]) for p in ("ke", "kp", "F_y", "n"))
        if fy <= 0:
            f = kp * (u - u[0])
            return f, np.zeros_like(u)
        if not modifiers.active:
            f = masing_force(u, RICHARD_ABBOTT, ra_params(ke, kp, fy, n))
            return f, running_work(u, f)
        k, fs, kel = self.population(params)
        e = np.zeros_like(u) if e_other is None else e_other
        return population_force(u, k, fs, kel, modifiers.asym, modifiers.inv_ew, e)

    def steady_term(self, params: Mapping[str, float]) -> tuple[int, np.ndarray]:
        ke, kp, fy, n = (float(params[p]) for p in ("ke", "kp", "F_y", "n"))
        if fy <= 0:
            return LINEAR, np.array([kp])
        return MASING_RA, ra_params(ke, kp, fy, n)

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        ke = summary.k_stick
        kp = min(summary.k_tip, 0.5 * ke)
        return {"ke": ke, "kp": kp, "F_y": summary.jenkins_strength(ke - kp), "n": 2.0}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"ke": guess["ke"], "kp": max(guess["kp"], 0.05 * guess["ke"]),
                "F_y": guess["F_y"], "n": 1.0}
