"""Backlash: a gap of total width g centred on u = 0 before the joint carries load."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.models.effects.base import InputEffect
from labjoint.models.inputs import ModelInputs
from labjoint.models.summary import LoopSummary


class Backlash(InputEffect):
    """u_eff = sign(u) max(|u| - g/2, 0); viscous sees d u_eff/dt, inertia the raw u."""

    name = "backlash"
    order = 1
    needs_multistart = True
    description = (
        "Clearance in the load path: a bolt loose in its hole or a gap in the fixture lets "
        "the parts move freely over a total travel g before the joint engages. The joint's "
        "elastic and hysteretic parts see u_eff = sign(u) max(|u| - g/2, 0), its viscous "
        "part d u_eff/dt; the mass before the gap (inertia) still sees the measured u.")
    signature = (
        "Zero force over a band of displacement around the loop's centre (a flat waist), "
        "apparent stiffness rising with amplitude as the gap becomes a smaller fraction of "
        "the stroke, impacts and high odd harmonics at engagement.")

    def transform(self, params: Mapping[str, float], inputs: ModelInputs) -> ModelInputs:
        half = 0.5 * float(params["gap"])
        if half <= 0:
            return inputs
        u, v = inputs.u_hist, inputs.v_hist
        ue = np.sign(u) * np.maximum(np.abs(u) - half, 0.0)
        # d u_eff/dt = v while engaged; per sample, the engaged fraction of the stroke
        # u +- |v| dt / 2 (continuous in u and in the gap, 1 everywhere as gap -> 0)
        a = 0.5 * np.abs(v) / inputs.fs
        inside = np.clip(np.minimum(u + a, half) - np.maximum(u - a, -half), 0.0, None)
        with np.errstate(invalid="ignore", divide="ignore"):
            engaged = np.where(a > 0, 1.0 - inside / (2 * a), (np.abs(u) > half).astype(float))
        return inputs.with_history(ue, v * np.clip(engaged, 0.0, 1.0), inputs.a_hist)

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        r = summary.largest
        k = summary.k_tip
        if k <= 0 or k < 0.9 * summary.k_stick:
            return {"gap": 0.0}   # tips softer than reversals: friction, not a gap
        # a spring behind a gap stiffens towards the tips: Fa = k_tip (U - g/2)
        return {"gap": float(np.clip(2.0 * (r.U - r.Fa / k), 0.0, r.U))}

    def neutral(self, summary: LoopSummary) -> dict[str, float]:
        return {"gap": 0.0}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"gap": max(guess["gap"], 0.1 * summary.smallest.U)}
