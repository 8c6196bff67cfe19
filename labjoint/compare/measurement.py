"""What the comparison loop needs of a measurement, and of a kind of measurement.

Fit, NRMSE, noise floor, significance, candidate ranking, diagnosis and the ladder are
written once, against these two protocols; what differs between kinds of measurement
(steady-sine cycles of a run, a record under any excitation, to come: an FRF at constant
force levels) lives in one module per kind (:mod:`labjoint.compare.kinds`).

A **measurement** (one prepared record) knows

- ``data``: a :class:`~labjoint.models.RunData`: the model inputs (the displacement
  history with its derivatives, priming included), the measured force and ``steady``,
  the mask of the samples it is judged on (NRMSE, design.md);
- ``units()``: the (start, stop) sample spans of its independent units (cycles of a sine,
  periods of a multisine, blocks of a random record); the paired significance test and
  the over-time map work per unit;
- ``noise()``: its own noise floor (:class:`RunNoise`), by the kind's stated method
  (``noise_method``, in words); :func:`noise_floor` pools them over a set;
- ``axes()``: where it sits on the set's axes (``frequency_hz`` and
  ``displacement_amplitude_m`` for sines), for the residual maps, the default split and
  the per-run JSON;
- ``figures(model_force)``: its energy loss and stiffness, measured and by the model
  (``FIGURES`` keys), for the per-run errors;
- ``renamed(name)``: the same measurement under another name (a set's names are unique).

A **kind** (named by the measurement's ``kind``, registered in
:data:`labjoint.compare.kinds.KINDS`) works on a set of measurements of that
kind: ``split`` (fit and validation measurements, and the rule in words), ``maps``
(residual maps over its axes, with ``to_dict``), ``curves`` (the physics curves, with
``to_dict``), ``loops`` (measured and model force against displacement), ``failures`` (where the model fails, in sentences) and ``evidence`` (what a
candidate effect changes, in a sentence).

A **predictor** is what gives the model's prediction for a measurement: a joint model
with its parameters, ``Model.eval(params, measurement.data)`` (:func:`predict`), or the
measurement's own ``predict(model, params)``: the ``frf`` kind evaluates the joint model
inside a structure (harmonic balance). A kind with its own predictor also gives its
``fit(model, fit, validation, init=None)`` and ``candidates(model, only)``, which the
diagnosis and the ladder use in place of the equation-error fitter.

Adding a kind: one module in :mod:`labjoint.compare.kinds` with a measurement class
satisfying :class:`Measurement` and a kind satisfying :class:`Kind`, registered in
``labjoint.compare.kinds.KINDS``, plus its tests (docs/architecture.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from labjoint.models import Model, Parameters, RunData

#: the figures every kind reports per measurement, measured and model
FIGURES = ("energy_loss_measured_j", "energy_loss_model_j", "stiffness_measured_n_per_m",
           "stiffness_model_n_per_m")


@dataclass(frozen=True)
class RunNoise:
    """Noise of one measurement: force and displacement std (N, m), force-equivalent std
    (N), its noise-floor NRMSE, and the units and windows the estimate used."""

    name: str
    force_std: float
    displacement_std: float
    equivalent_std: float
    nrmse: float
    n_cycles: int
    n_windows: int


@runtime_checkable
class Measurement(Protocol):
    """One prepared measurement (module docstring)."""

    kind: ClassVar[str]
    noise_method: ClassVar[str]
    name: str
    data: RunData
    path: str | None
    metadata: dict[str, Any]

    def units(self) -> np.ndarray: ...

    def noise(self) -> RunNoise: ...

    def axes(self) -> dict[str, float]: ...

    def figures(self, model_force: np.ndarray) -> dict[str, float]: ...

    def renamed(self, name: str) -> Measurement: ...


@dataclass(frozen=True)
class NoiseFloor:
    """Pooled noise floor (NRMSE) of a set of measurements and the per-measurement figures."""

    nrmse: float
    runs: tuple[RunNoise, ...]
    method: str = ""

    def by_run(self) -> dict[str, float]:
        return {r.name: r.nrmse for r in self.runs}

    def over(self, ms: Sequence[Measurement], names: Sequence[str] | None = None) -> float:
        """The noise floor pooled over the named measurements of ``ms`` (all by default)."""
        keep = None if names is None else set(names)
        per = {r.name: r for r in self.runs}
        return _pooled([(m, per[m.name]) for m in ms
                        if m.name in per and (keep is None or m.name in keep)])

    def to_dict(self) -> dict[str, Any]:
        return {"nrmse": self.nrmse, "method": self.method,
                "runs": [{"run": r.name, "nrmse": r.nrmse, "force_std_n": r.force_std,
                          "displacement_std_m": r.displacement_std,
                          "equivalent_std_n": r.equivalent_std} for r in self.runs]}


def noise_floor(ms: Sequence[Measurement]) -> NoiseFloor:
    """Pooled noise floor: sqrt(sum_m n_m sigma_m^2 / sum_m sum F^2) over the judged samples,
    sigma_m each measurement's force-equivalent noise std (the NRMSE's weighting)."""
    per = tuple(m.noise() for m in ms)
    methods = list(dict.fromkeys(type(m).noise_method for m in ms))
    return NoiseFloor(_pooled(list(zip(ms, per))), per, "; ".join(methods))


def _pooled(pairs: Sequence[tuple[Measurement, RunNoise]]) -> float:
    num = den = 0.0
    for m, n in pairs:
        f = m.data.force[m.data.steady]
        if np.isfinite(n.equivalent_std):
            num += f.size * n.equivalent_std ** 2
            den += float(f @ f)
    return float(np.sqrt(num / den)) if den > 0 else float("nan")


class Kind(Protocol):
    """The set-level operations of one kind of measurement (module docstring)."""

    name: str

    def split(self, ms: Sequence[Any]) -> tuple[list[Any], list[Any], str]: ...

    def maps(self, evals: Sequence[Any], noise: dict[str, float]) -> Any:
        """Residual maps of evaluated measurements (``RunEval``); ``noise``: name -> floor."""

    def curves(self, evals: Sequence[Any]) -> Any:
        """Physics curves, measured against model, of evaluated measurements."""

    def loops(self, evals: Sequence[Any]) -> dict[str, dict[str, Any]]:
        """Per measurement: displacement, measured and model force to draw against each
        other (keys ``displacement_m``, ``force_measured_n``, ``force_model_n``)."""

    def failures(self, ev: Any, maps: Any, curves: Any, floor: float,
                 factor: float) -> list[dict[str, Any]]:
        """Where the model fails (``ev``: an ``Evaluation``), as {"where", "text"} findings."""

    def evidence(self, effect: str, base: Any, cand: Any, base_maps: Any, cand_maps: Any,
                 fit: Any, validation: str) -> str:
        """What adding ``effect`` changes on the data, in one sentence."""


def predict(model: Model, params: Parameters, m: Measurement) -> np.ndarray:
    """The joint model's force on the measurement's record samples (N); a measurement
    with its own predictor (``m.predict``: e.g. the model inside a structure) gives its
    prediction in the units of its ``data.force``."""
    own = getattr(m, "predict", None)
    if own is not None:
        return own(model, params)
    return model.eval(params, m.data)


def unit_sums(x2: np.ndarray, units: np.ndarray) -> np.ndarray:
    """Sum of ``x2`` over each (start, stop) span."""
    c = np.concatenate([[0.0], np.cumsum(x2)])
    return c[units[:, 1]] - c[units[:, 0]]
