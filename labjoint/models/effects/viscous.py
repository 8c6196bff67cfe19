"""Linear viscous damping: F = c du/dt."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.models.effects import _steady
from labjoint.models.effects.base import ForceEffect
from labjoint.models.inputs import ModelInputs
from labjoint.models.summary import LoopSummary


class Viscous(ForceEffect):
    """F = c du/dt (the linear visco-elastic joint model of seed 001 with k)."""

    name = "viscous"
    steady_code = _steady.V_LINEAR
    description = (
        "Rate-dependent loss: a force proportional to the relative velocity, F = c du/dt, as "
        "from a squeezed lubricant or air film, material damping or, more often, the "
        "energy-equivalent stand-in for friction in linear visco-elastic joint models "
        "(seed 001). With a spring it draws an ellipse.")
    signature = (
        "Elliptic loop; dissipation per cycle pi c omega U^2 grows in proportion to "
        "frequency and to amplitude squared (equivalent damping independent of amplitude), "
        "no harmonics.")

    def basis(self, inputs: ModelInputs) -> np.ndarray:
        return inputs.v_hist

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        return {"c": summary.c_eq}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        r = summary.largest
        c_ref = r.Fa / (2 * np.pi * r.frequency_hz * r.U)
        return {"c": max(guess["c"], 0.01 * c_ref)}
