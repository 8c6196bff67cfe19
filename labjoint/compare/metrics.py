"""Measured against model: NRMSE (pooled and per run), energy-loss and stiffness errors.

NRMSE (design.md): rms(F_measured - F_model) / rms(F_measured) over the judged (steady)
samples of every measurement in the set, pooled (each counts by its samples). Energy
loss and stiffness come from the measurement's own ``figures`` (for sines the
hysteresis-loop quantities of seed 002, Eq. 1, per steady cycle; for records the energy
dissipated over the record and the least-squares stiffness), computed from the same
displacement with the measured force and with the model force, so both sides see the
same estimator; the errors are 100 (model - measured) / measured.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.compare.measurement import Measurement, predict, unit_sums
from labjoint.models import Model, Parameters, nrmse_from_sums, pooled_nrmse


@dataclass(frozen=True, eq=False)
class RunEval:
    """A model evaluated on one measurement: model force on the record samples and the
    measurement's figures (energy loss, stiffness; :data:`.measurement.FIGURES`)."""

    run: Measurement
    model_force: np.ndarray
    figures: dict[str, float] = field(default_factory=dict)

    @property
    def name(self) -> str:
        return self.run.name

    @property
    def residual(self) -> np.ndarray:
        """F_measured - F_model on the record samples (N)."""
        return self.run.data.force - self.model_force

    @property
    def sse(self) -> float:
        e = self.residual[self.run.data.steady]
        return float(e @ e)

    @property
    def ssf(self) -> float:
        f = self.run.data.force[self.run.data.steady]
        return float(f @ f)

    @property
    def nrmse(self) -> float:
        return nrmse_from_sums(self.sse, self.ssf)

    def unit_sse(self) -> np.ndarray:
        """Sum of squared residuals of each independent unit (N^2)."""
        return unit_sums(self.residual ** 2, self.run.units())

    def unit_ssf(self) -> np.ndarray:
        return unit_sums(self.run.data.force ** 2, self.run.units())

    def _figure(self, key: str) -> float:
        return float(self.figures.get(key, float("nan")))

    @property
    def energy_measured(self) -> float:
        """Energy loss, measured (J; per cycle for sines, seed 002 Fig. 2 loop area)."""
        return self._figure("energy_loss_measured_j")

    @property
    def energy_model(self) -> float:
        return self._figure("energy_loss_model_j")

    @property
    def stiffness_measured(self) -> float:
        """Stiffness, least-squares slope (N/m)."""
        return self._figure("stiffness_measured_n_per_m")

    @property
    def stiffness_model(self) -> float:
        return self._figure("stiffness_model_n_per_m")

    @property
    def energy_loss_error_pct(self) -> float:
        m = self.energy_measured
        return 100.0 * (self.energy_model - m) / m if m != 0 else float("nan")

    @property
    def stiffness_error_pct(self) -> float:
        m = self.stiffness_measured
        return 100.0 * (self.stiffness_model - m) / m if m != 0 else float("nan")

    def to_dict(self) -> dict[str, Any]:
        return {"run": self.name, "nrmse": self.nrmse,
                "energy_loss_error_pct": self.energy_loss_error_pct,
                "stiffness_error_pct": self.stiffness_error_pct,
                **self.run.axes(), **self.figures}


def evaluate_run(model: Model, params: Parameters | dict, run: Measurement,
                 loops: bool = True) -> RunEval:
    """Evaluate ``model`` on ``run`` (and, if ``loops``, its energy and stiffness figures)."""
    F = predict(model, params, run)
    return RunEval(run, F, run.figures(F) if loops else {})


@dataclass(frozen=True, eq=False)
class Evaluation:
    """A model with parameters evaluated on a set of runs."""

    model: Model
    params: Parameters
    runs: tuple[RunEval, ...]

    def subset(self, names: Iterable[str] | None) -> list[RunEval]:
        if names is None:
            return list(self.runs)
        keep = set(names)
        return [r for r in self.runs if r.name in keep]

    def nrmse(self, names: Iterable[str] | None = None) -> float:
        """Pooled NRMSE over the named runs (all by default)."""
        rs = self.subset(names)
        return pooled_nrmse([r.sse for r in rs], [r.ssf for r in rs])

    def by_run(self) -> dict[str, float]:
        return {r.name: r.nrmse for r in self.runs}

    def runs_measured(self) -> list[Measurement]:
        """The measurements evaluated."""
        return [r.run for r in self.runs]

    def run(self, name: str) -> RunEval:
        for r in self.runs:
            if r.name == name:
                return r
        raise KeyError(name)


def evaluate(model: Model, params: Parameters | dict, runs: Sequence[Measurement],
             loops: bool = True) -> Evaluation:
    """Evaluate ``model`` with ``params`` on every run."""
    p = params if isinstance(params, Parameters) else model.make_params(values=params)
    return Evaluation(model, p, tuple(evaluate_run(model, p, r, loops) for r in runs))
