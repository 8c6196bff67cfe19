"""Measured against model: NRMSE (pooled and per run), energy-loss and stiffness errors.

NRMSE (design.md): rms(F_measured - F_model) / rms(F_measured) over the steady samples
of every run in the set, pooled (each run counts by its samples). Energy loss and
stiffness are the hysteresis-loop quantities of seed 002 (Eq. 1: loop area W_d; loop
slope k, least squares of F on U), computed per steady cycle by
:func:`labjoint.identify.loop.loop_metrics` from the same displacement with the measured
force and with the model force, so both sides see the same estimator; the errors are
100 (model - measured) / measured, from the means over the steady cycles.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.compare.runs import PreparedRun
from labjoint.identify.loop import loop_metrics
from labjoint.models import Model, Parameters, nrmse_from_sums, pooled_nrmse


@dataclass(frozen=True, eq=False)
class RunEval:
    """A model evaluated on one run: model force on the record samples and derived figures."""

    run: PreparedRun
    model_force: np.ndarray
    loop_measured: dict[str, np.ndarray] = field(default_factory=dict)
    loop_model: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def name(self) -> str:
        return self.run.name

    @property
    def residual(self) -> np.ndarray:
        """F_measured - F_model on the record samples (N)."""
        return self.run.data.force - self.model_force

    @property
    def sse(self) -> float:
        e = self.residual[self.run.steady]
        return float(e @ e)

    @property
    def ssf(self) -> float:
        f = self.run.data.force[self.run.steady]
        return float(f @ f)

    @property
    def nrmse(self) -> float:
        return nrmse_from_sums(self.sse, self.ssf)

    def cycle_sse(self) -> np.ndarray:
        """Sum of squared residuals of each steady cycle (N^2)."""
        e2 = self.residual ** 2
        return np.array([e2[a:b].sum() for a, b in self.run.cycles])

    def cycle_ssf(self) -> np.ndarray:
        f2 = self.run.data.force ** 2
        return np.array([f2[a:b].sum() for a, b in self.run.cycles])

    def _mean(self, d: dict[str, np.ndarray], key: str) -> float:
        x = d.get(key)
        x = np.asarray(x, dtype=float)[np.isfinite(x)] if x is not None else np.zeros(0)
        return float(np.mean(x)) if x.size else float("nan")

    @property
    def energy_measured(self) -> float:
        """Energy loss per cycle, measured (J, seed 002 Fig. 2 loop area)."""
        return self._mean(self.loop_measured, "energy_loss")

    @property
    def energy_model(self) -> float:
        return self._mean(self.loop_model, "energy_loss")

    @property
    def stiffness_measured(self) -> float:
        """Loop stiffness, least-squares slope (N/m)."""
        return self._mean(self.loop_measured, "stiffness_lsq")

    @property
    def stiffness_model(self) -> float:
        return self._mean(self.loop_model, "stiffness_lsq")

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
                "frequency_hz": self.run.frequency_hz,
                "displacement_amplitude_m": self.run.amplitude_m,
                "energy_loss_measured_j": self.energy_measured,
                "energy_loss_model_j": self.energy_model,
                "stiffness_measured_n_per_m": self.stiffness_measured,
                "stiffness_model_n_per_m": self.stiffness_model}


def _loop(u: np.ndarray, f: np.ndarray, groups: list[np.ndarray], freq: float
          ) -> dict[str, np.ndarray]:
    if not groups:
        return {}
    parts = [loop_metrics(u, f, g, freq) for g in groups]
    return {k: np.concatenate([p[k] for p in parts]) for k in ("energy_loss", "stiffness_lsq",
                                                               "displacement_amplitude",
                                                               "force_amplitude")}


def evaluate_run(model: Model, params: Parameters | dict, run: PreparedRun,
                 loops: bool = True) -> RunEval:
    """Evaluate ``model`` on ``run`` (and, if ``loops``, the loop quantities of both forces)."""
    F = model.eval(params, run.data)
    if not loops:
        return RunEval(run, F)
    groups = run.cycle_bounds()
    u = run.data.inputs.u
    return RunEval(run, F, _loop(u, run.data.force, groups, run.frequency_hz),
                   _loop(u, F, groups, run.frequency_hz))


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

    def run(self, name: str) -> RunEval:
        for r in self.runs:
            if r.name == name:
                return r
        raise KeyError(name)


def evaluate(model: Model, params: Parameters | dict, runs: Sequence[PreparedRun],
             loops: bool = True) -> Evaluation:
    """Evaluate ``model`` with ``params`` on every run."""
    p = params if isinstance(params, Parameters) else model.make_params(values=params)
    return Evaluation(model, p, tuple(evaluate_run(model, p, r, loops) for r in runs))
