"""The ``sine`` kind: steady cycles of runs under a steady sine.

Measurement: :class:`~labjoint.compare.prepared.PreparedRun` (made by
:func:`labjoint.compare.runs.prepare_run`); units: the steady cycles; noise floor: the
cycle-to-cycle scatter (:mod:`labjoint.compare.noise`); axes: frequency and
displacement amplitude; maps over phase, quadrant, reversals, harmonics and the
frequency x amplitude grid (:mod:`labjoint.compare.residuals`); physics curves: energy
loss and stiffness against amplitude and frequency (:mod:`labjoint.compare.curves`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from labjoint.compare.curves import PhysicsCurves, mean_loops, physics_curves
from labjoint.compare.describe import failures
from labjoint.compare.evidence import evidence
from labjoint.compare.metrics import Evaluation, RunEval
from labjoint.compare.residuals import ResidualMaps, residual_maps
from labjoint.compare.runs import PreparedRun, default_split
from labjoint.models import FitResult


@dataclass(frozen=True)
class SineKind:
    """Set-level operations of steady-sine runs (:class:`labjoint.compare.measurement.Kind`)."""

    name: str = "sine"

    def split(self, ms: Sequence[PreparedRun]) -> tuple[list[PreparedRun], list[PreparedRun], str]:
        return default_split(ms)

    def maps(self, evals: Sequence[RunEval], noise: dict[str, float]) -> ResidualMaps:
        return residual_maps(evals, noise)

    def curves(self, evals: Sequence[RunEval]) -> PhysicsCurves:
        return physics_curves(evals)

    def loops(self, evals: Sequence[RunEval]) -> dict[str, dict[str, Any]]:
        return mean_loops(evals)

    def failures(self, ev: Evaluation, maps: ResidualMaps, curves: PhysicsCurves, floor: float,
                 factor: float) -> list[dict[str, Any]]:
        return failures(ev, maps, curves, floor, factor)

    def evidence(self, effect: str, base: Evaluation, cand: Evaluation, base_maps: ResidualMaps,
                 cand_maps: ResidualMaps, fit: FitResult, validation: str) -> str:
        return evidence(effect, base, cand, base_maps, cand_maps, fit, validation)


SINE = SineKind()
