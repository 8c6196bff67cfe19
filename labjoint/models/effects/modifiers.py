"""Modifiers of the hysteretic part's slip strengths: asymmetric_slip and wear."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.errors import InputError
from labjoint.models.effects.base import ModifierEffect, SlipModifiers
from labjoint.models.summary import LoopSummary


class AsymmetricSlip(ModifierEffect):
    """Slip strengths x (1 + asym) while sliding in +u, x (1 - asym) in -u."""

    name = "asymmetric_slip"
    description = (
        "The interface resists sliding more in one direction than the other: machining lay, "
        "a tilted contact, or a bolt pulled to one side of its hole. Every slip strength of "
        "the model's hysteretic part is scaled by (1 + asym) while sliding in +u and by "
        "(1 - asym) while sliding in -u.")
    signature = (
        "Even harmonics: the loop's plateaus are unequal, so its centre moves off zero force "
        "(harmonic 0). For Masing-type laws (coulomb, iwan, richard_abbott) under a "
        "symmetric displacement the steady loop is the symmetric one shifted, so only the "
        "mean force changes; for bouc_wen and valanis the branch shapes differ too and a "
        "2nd harmonic appears.")

    def modify(self, params: Mapping[str, float], mods: SlipModifiers) -> SlipModifiers:
        return SlipModifiers(asym=float(params["asym"]), inv_ew=mods.inv_ew)

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        return {"asym": float(np.clip(summary.largest.asymmetry, -0.5, 0.5))}

    def neutral(self, summary: LoopSummary) -> dict[str, float]:
        return {"asym": 0.0}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"asym": 0.1}


class Wear(ModifierEffect):
    """Slip strengths x exp(-E_d / E_w), E_d the friction energy dissipated so far."""

    name = "wear"
    log_params = frozenset({"E_w"})
    description = (
        "Fretting wears and smooths the asperities, and debris forms a third body, so the "
        "interface weakens as it works: every slip strength of the hysteretic part decays "
        "as exp(-E_d/E_w), E_d the friction energy the joint has dissipated since the "
        "record began (seed 001 notes dissipation settling over hundreds of cycles).")
    signature = (
        "Loss drifts from cycle to cycle at constant excitation (no true steady state); in "
        "macro-slip the loss per cycle decays like exp(-E_d/E_w), in micro-slip weaker "
        "sliders slip more and loss can rise; stiffness drifts with it.")

    def modify(self, params: Mapping[str, float], mods: SlipModifiers) -> SlipModifiers:
        ew = float(params["E_w"])
        if not ew > 0:
            raise InputError(f"must be > 0 J, got {ew:g}", field="wear.E_w")
        return SlipModifiers(asym=mods.asym, inv_ew=1.0 / ew)

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        r = max(summary.runs, key=lambda x: x.energy)
        e = r.cycle_energy
        weak = 1e3 * max(summary.energy_scale, 1e-12)
        if e.size < 4 or np.any(e <= 0):
            return {"E_w": weak}
        slope = np.polyfit(np.cumsum(e), np.log(e), 1)[0]   # d ln E / d E_d = -1/E_w
        return {"E_w": float(-1.0 / slope) if slope < -1.0 / weak else weak}

    def neutral(self, summary: LoopSummary) -> dict[str, float]:
        # 1000 x the most energy the data could dissipate: strengths change < 0.1 %
        return {"E_w": 1e3 * max(summary.energy_scale, 1e-12)}
