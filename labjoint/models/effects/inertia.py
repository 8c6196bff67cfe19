"""Inertia of the mass between the force sensor and the interface: F = m d2u/dt2."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.models.effects import _steady
from labjoint.models.effects.base import ForceEffect
from labjoint.models.inputs import ModelInputs
from labjoint.models.summary import LoopSummary


class Inertia(ForceEffect):
    """F = m d2u/dt2 (acceleration of the measured, untransformed displacement)."""

    name = "inertia"
    steady_code = _steady.A_LINEAR
    description = (
        "The force sensor does not sit on the interface: the mass m between them must be "
        "accelerated, so the sensor reads the joint force plus m d2u/dt2. For a sinusoid "
        "this is a negative stiffness -m omega^2 in phase with displacement, growing with "
        "frequency. It moves with the measured displacement (a backlash gap does not act on it).")
    signature = (
        "Apparent stiffness falls like frequency squared (k - m omega^2), the same at every "
        "amplitude; no dissipation.")

    def basis(self, inputs: ModelInputs) -> np.ndarray:
        return inputs.a_hist

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        w2 = np.array([(2 * np.pi * r.frequency_hz) ** 2 for r in summary.runs])
        k = np.array([r.k_eq for r in summary.runs])
        if np.ptp(w2) < 0.1 * w2.max():
            return {"m": 0.0}
        return {"m": float(-np.polyfit(w2, k, 1)[0])}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        w2 = max((2 * np.pi * r.frequency_hz) ** 2 for r in summary.runs)
        return {"m": max(abs(guess["m"]), 0.01 * abs(summary.k_eq) / w2)}
