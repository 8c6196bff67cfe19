"""What a diagnosis finds (:mod:`labjoint.compare.diagnosis`): its settings, each candidate
effect refitted and judged, and the whole result with the CLI/REST JSON (:meth:`Diagnosis.to_dict`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from labjoint.compare.kinds import kind_of
from labjoint.compare.measurement import Measurement, NoiseFloor
from labjoint.compare.metrics import Evaluation
from labjoint.compare.significance import PairedTest, SignificanceSettings
from labjoint.models import FitResult, Model
from labjoint.models.asymmetry import EVEN, amplitude, asymmetry
from labjoint.models.result import parameter_table

DEFAULT_FACTOR = 1.5


@dataclass(frozen=True)
class DiagnoseSettings:
    """Settings of a diagnosis (see the module docstring and :mod:`.significance`)."""

    factor: float = DEFAULT_FACTOR
    significance: SignificanceSettings = SignificanceSettings()
    n_jobs: int | None = None
    multistart: int | str = "auto"
    seed: int = 0
    warm: bool = True
    candidates: tuple[str, ...] | None = None
    refine: int = 1
    #: where candidate refits run: None (``n_jobs`` local processes) or an executor
    #: (``submit(fn, *args)``, optionally ``share(obj)``; :func:`.candidates._on_executor`)
    executor: Any = field(default=None, compare=False, repr=False)


@dataclass
class CandidateResult:
    """One candidate effect refitted and judged."""

    effect: str
    fit: FitResult
    evaluation: Evaluation
    nrmse_after: float
    nrmse_after_validation: float
    test: PairedTest
    significant: bool
    reason: str
    evidence: str = ""
    explanation: str = ""
    tie_with: list[str] = field(default_factory=list)
    tie_reason: str = ""
    asymmetry: list[dict[str, Any]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        d = {"effect": self.effect, "nrmse_after": self.nrmse_after,
             "nrmse_after_validation": self.nrmse_after_validation,
             "significant": self.significant, "p_value": self.test.p, "test": self.reason,
             "evidence": self.evidence, "explanation": self.explanation,
             "model": self.fit.model.expr,
             "parameters": parameters_dict(self.fit)}
        if self.tie_with:
            d["tie"] = {"with": list(self.tie_with), "reason": self.tie_reason}
        if self.asymmetry:
            d["asymmetry"] = self.asymmetry
        return d


def fit_asymmetry(fit: FitResult, runs: Sequence[Measurement]) -> list[dict[str, Any]]:
    """The even effects' asymmetry (:mod:`labjoint.models.asymmetry`) at the largest
    displacement amplitude of the runs (none for FRF sets and backbones: their data are
    phasors, frequencies and damping ratios)."""
    if not any(n in EVEN for n in fit.model.names) or not runs or runs[0].kind in ("frf", "backbone"):
        return []
    if hasattr(runs[0], "displacement_amplitude"):     # modal records: the model's modal amplitude
        u = max(r.displacement_amplitude(fit.model, fit.params_) for r in runs)
        return asymmetry(fit.model, fit.params_.valuesdict(), u)
    return asymmetry(fit.model, fit.params_.valuesdict(), amplitude([r.data for r in runs]))


def parameters_dict(fit: FitResult) -> dict[str, dict[str, Any]]:
    """``{"<effect>.<param>": {"value", "stderr", "unit"}}`` of a fit, and ``"flag"`` where
    the standard error is undetermined (then ``stderr`` is null) or exceeds the value
    (:func:`labjoint.models.result.parameter_flags`)."""
    return parameter_table(fit.params_, fit.stderr_, fit.flags_)


@dataclass
class Diagnosis:
    """Everything a diagnosis found; :meth:`to_dict` gives the CLI/REST JSON."""

    model: Model
    base: FitResult
    evaluation: Evaluation
    noise: NoiseFloor
    noise_floor_validation: float
    fit_runs: list[str]
    validation_runs: list[str]
    split_rule: str
    maps: Any
    curves: Any
    failures: list[dict[str, Any]]
    candidates: list[CandidateResult]
    not_applicable: dict[str, str]
    adequate: bool
    verdict: str
    settings: DiagnoseSettings
    timing_s: dict[str, float] = field(default_factory=dict)

    @property
    def nrmse(self) -> float:
        return self.evaluation.nrmse()

    @property
    def nrmse_validation(self) -> float:
        return self.evaluation.nrmse(self.validation_runs)

    @property
    def best(self) -> CandidateResult | None:
        sig = [c for c in self.candidates if c.significant]
        return sig[0] if sig else None

    def to_dict(self, full: bool = False) -> dict[str, Any]:
        d: dict[str, Any] = {
            "model": self.model.expr, "kind": kind_of(self.evaluation.runs_measured()).name,
            "nrmse": self.nrmse, "noise_floor": self.noise.nrmse,
            "adequate": self.adequate, "verdict": self.verdict, "factor": self.settings.factor,
            "nrmse_validation": self.nrmse_validation,
            "noise_floor_validation": self.noise_floor_validation,
            "failures": self.failures,
            "candidates": [c.to_dict() for c in self.candidates],
            "not_applicable": dict(self.not_applicable),
            "test": self.settings.significance.describe(),
            "split": self.split_rule, "fit_runs": self.fit_runs,
            "validation_runs": self.validation_runs,
            "parameters": parameters_dict(self.base),
            "flags": self.base.flags_,
            "asymmetry": fit_asymmetry(self.base, [r.run for r in self.evaluation.runs]),
            "runs": [r.to_dict() for r in self.evaluation.runs],
            "timing_s": self.timing_s,
        }
        best = self.candidates[0] if self.candidates else None
        if best is not None and best.tie_with:
            d["tie"] = {"effects": [best.effect, *best.tie_with], "reason": best.tie_reason}
        if full:
            d["maps"] = self.maps.to_dict()
            d["curves"] = self.curves.to_dict()
            d["noise"] = self.noise.to_dict()
        return d
