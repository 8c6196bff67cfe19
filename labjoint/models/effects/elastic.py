"""Elastic and static force terms: linear_stiffness, cubic_stiffness, offset."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from labjoint.models.effects import _steady
from labjoint.models.effects.base import ForceEffect
from labjoint.models.inputs import ModelInputs
from labjoint.models.summary import LoopSummary


class LinearStiffness(ForceEffect):
    """F = k u."""

    name = "linear_stiffness"
    steady_code = _steady.U_LINEAR
    description = (
        "The joint and the structure around it deform elastically: a force proportional to "
        "the relative displacement, F = k u, stores energy and returns it within each cycle. "
        "It is the stick stiffness of a fully stuck interface, or the part of the load path "
        "that bypasses the friction interface (bolt shank bending, adjacent material).")
    signature = (
        "A straight line through the loop's centre: stiffness independent of amplitude and "
        "frequency, no dissipation, no harmonics.")

    def basis(self, inputs: ModelInputs) -> np.ndarray:
        return inputs.u_hist

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        return {"k": summary.k_eq}


class CubicStiffness(ForceEffect):
    """F = k3 u^3."""

    name = "cubic_stiffness"
    steady_code = _steady.U_CUBE
    description = (
        "Geometric or contact stiffening (or softening when k3 < 0): the restoring force "
        "grows with the cube of displacement, F = k3 u^3, e.g. from Hertzian contact patches "
        "growing under load or membrane stretching. Conservative: it bends the loop's axis "
        "without opening it.")
    signature = (
        "Equivalent stiffness rises with amplitude as k + (3/4) k3 U^2, loop area unchanged "
        "(no extra loss), odd harmonics (3rd) in force for a sinusoidal displacement.")

    def basis(self, inputs: ModelInputs) -> np.ndarray:
        return inputs.u_hist ** 3

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        s, l = summary.smallest, summary.largest
        du2 = l.U ** 2 - s.U ** 2
        if du2 <= 0.1 * l.U ** 2:
            return {"k3": 0.0}
        # first harmonic of u^3 is (3/4) U^2 u: k_eq(U) = k + (3/4) k3 U^2
        return {"k3": float(4.0 / 3.0 * (l.k_eq - s.k_eq) / du2)}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"k3": max(abs(guess["k3"]), abs(summary.k_eq) / summary.largest.U ** 2)}


class Offset(ForceEffect):
    """F = F0."""

    name = "offset"
    steady_code = _steady.CONST
    description = (
        "A constant force: the static preload carried through the joint by the fixture, or "
        "a zero offset of the force sensor or its amplifier. It shifts the loop vertically "
        "and plays no part in the dynamics.")
    signature = (
        "The loop's mean force is not zero (harmonic 0 of the force, an even harmonic), the "
        "same at every amplitude and frequency, no effect on loop shape or area.")

    def basis(self, inputs: ModelInputs) -> np.ndarray:
        return np.ones_like(inputs.u_hist)

    def guess(self, summary: LoopSummary) -> dict[str, float]:
        return {"F0": float(np.mean([r.F_mean for r in summary.runs]))}

    def scales(self, summary: LoopSummary, guess: Mapping[str, float]) -> dict[str, float]:
        return {"F0": max(abs(guess["F0"]), summary.largest.Fa)}
