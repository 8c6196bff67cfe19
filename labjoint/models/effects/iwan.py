"""Segalman's 4-parameter parallel Iwan model (F_S, K_T, chi, beta): micro- to macro-slip.

Slider-strength density (vocabulary, Segalman 2005 via seed 001): rho(phi) = R phi^chi
on (0, phi_max) plus S delta(phi - phi_max), unit-stiffness elements slipping at
displacement phi. Without modifiers the model is simulated exactly by the extended
Masing rules on its closed-form backbone
F = F_S / D [(1 + beta) x - x^(chi + 2) / (chi + 2)], x = |u| / phi_max <= 1, F_S beyond,
D = beta + (chi + 1)/(chi + 2). With a modifier (asymmetric_slip, wear) the density is
discretised into sliders (``_population.iwan_population``: 135 geometric bins of ratio
0.95 on (1e-3, 1) phi_max, two Gauss sliders per bin, a bottom pair and the delta),
whose micro-slip energy per cycle matches the closed form
4 R U^(3+chi) / ((chi+2)(chi+3)) to < 1e-3 for 1e-3 <= U/phi_max <= 1.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.models.effects._masing import IWAN, iwan_params, masing_force, running_work
from labjoint.models.effects._population import iwan_population, population_force
from labjoint.models.effects._steady import MASING_IWAN, NONE
from labjoint.models.effects.base import NO_MODIFIERS, HystereticEffect, SlipModifiers
from labjoint.models.summary import LoopSummary

CHI_MIN = -1.0 + 1e-6


def _chi(params: Mapping[str, float]) -> float:
    return max(float(params["chi"]), CHI_MIN)


class Iwan(HystereticEffect):
    """Segalman 4-parameter Iwan: power-law micro-slip, macro-slip at F_S."""

    name = "iwan"
    log_params = frozenset({"F_S", "K_T"})
    description = (
        "A bolted interface slips progressively: where the pressure is low the contact "
        "slips first (micro-slip) while the rest sticks, until the whole interface slides "
        "at the macro-slip force F_S. Segalman's parallel Iwan network represents this as "
        "a continuum of Jenkins elements whose strengths follow a power law of exponent chi "
        "plus a lump (weight beta) at the strongest, with initial stiffness K_T (seed 001).")
    signature = (
        "Micro-slip: dissipation per cycle grows like amplitude^(3+chi), i.e. 2.5-3 for "
        "measured joints, and stiffness softens with amplitude from K_T; macro-slip: force "
        "saturates at F_S and dissipation grows linearly; odd harmonics; independent of "
        "frequency (Masing loops).")

    def simulate(self, params: Mapping[str, float], u: np.ndarray,
                 modifiers: SlipModifiers = NO_MODIFIERS,
                 e_other: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        F_S, K_T = float(params["F_S"]), float(params["K_T"])
        chi, beta = _chi(params), float(params["beta"])
        if F_S <= 0 or K_T <= 0:
            return np.zeros_like(u), np.zeros_like(u)
        if not modifiers.active:
            f = masing_force(u, IWAN, iwan_params(F_S, K_T, chi, beta))
            return f, running_work(u, f)
        k, fs = iwan_population(F_S, K_T, chi, beta)
        e = np.zeros_like(u) if e_other is None else e_other
        return population_force(u, k, fs, 0.0, modifiers.asym, modifiers.inv_ew, e)

    def steady_term(self, params: Mapping[str, float]) -> tuple[int, np.ndarray]:
        F_S, K_T = float(params["F_S"]), float(params["K_T"])
        if F_S <= 0 or K_T <= 0:
            return NONE, np.zeros(0)
        return MASING_IWAN, iwan_params(F_S, K_T, _chi(params), float(params["beta"]))

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        K_T = summary.k_stick
        chi = float(np.clip(summary.energy_exponent - 3.0, -0.8, 0.8))
        beta = 0.5
        r = summary.largest
        d = beta + (chi + 1) / (chi + 2)
        # micro-slip energy E = C F_S^-(chi+1) (closed form above) solved for F_S
        c = (4 * (chi + 1) / (d * (chi + 2) * (chi + 3)) * r.U ** (chi + 3)
             * ((1 + beta) / (K_T * d)) ** (-(chi + 2)))
        F_S = (c / r.energy) ** (1 / (chi + 1)) if r.energy > 0 else 2 * r.Fa
        return {"F_S": float(np.clip(F_S, r.Fa, 100 * r.Fa)), "K_T": K_T, "chi": chi, "beta": beta}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"F_S": guess["F_S"], "K_T": guess["K_T"], "chi": 0.3, "beta": 0.5}
