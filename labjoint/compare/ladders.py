"""The ladder: successive models (start, + effect, + effect, ...) with their metrics.

Automatic mode: diagnose the current model (:mod:`labjoint.compare.diagnosis`); while it is
not adequate and a candidate improves it significantly, add the best one (its warm refit
becomes the next step's fit) and diagnose again, up to ``max_steps`` additions. A tie
for best is broken by the lower validation NRMSE and recorded in the step.

A step may lower the set's NRMSE while moving some runs' dissipation away from the
measurement (issue 33: the 1 Vpp runs' energy-loss error -2.9 % -> -12.3 %). The
automatic ladder does not take such a step: a significant candidate that makes any
run's energy-loss error worse (:func:`worsened`) is refused, named in the step's
``refused`` list, and the next significant candidate is tried; when every one is
refused the ladder stops and says which runs each would have made worse.

Manual mode: the steps are the successive prefixes of the given expression (``a``,
``a+b``, ``a+b+c``; prefixes that are not valid models, e.g. a modifier before any
hysteretic effect, are skipped), each fitted warm from the one before; the last step is
diagnosed to decide adequacy.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.compare.diagnosis import (CandidateResult, DiagnoseSettings, Diagnosis,
                                       diagnose_prepared, judged_runs, parameters_dict)
from labjoint.compare.kinds import kind_of
from labjoint.compare.measurement import Measurement, noise_floor
from labjoint.compare.metrics import Evaluation, evaluate
from labjoint.compare.runs import split_by_names
from labjoint.errors import InputError
from labjoint.models import FitResult, Model, ModelFitter


#: failures listed per step that is not adequate (its diagnosis's worst first)
REMAINING = 5


@dataclass
class LadderStep:
    """One rung: the model, the effect it added, its metrics and (auto mode) diagnosis."""

    model: str
    added: str | None
    nrmse: float
    nrmse_validation: float
    adequate: bool
    parameters: dict[str, Any]
    verdict: str = ""
    tie: dict[str, Any] | None = None
    candidates: list[dict[str, Any]] = field(default_factory=list)
    diagnosis: Diagnosis | None = None
    refused: list[dict[str, Any]] = field(default_factory=list)
    worse: list[dict[str, Any]] = field(default_factory=list)
    run_errors: list[dict[str, Any]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        d = {"model": self.model, "added": self.added, "nrmse": self.nrmse,
             "nrmse_validation": self.nrmse_validation, "adequate": self.adequate,
             "verdict": self.verdict, "parameters": self.parameters,
             "candidates": self.candidates}
        if self.tie:
            d["tie"] = self.tie
        curves = getattr(getattr(self.diagnosis, "maps", None), "step_curves", None)
        if curves is not None:           # backbones: the step's model at the measured amplitudes
            d["backbone_curves"] = curves()
        if self.diagnosis is not None and not self.adequate:   # what remains, and where
            d["remaining"] = [f["text"] for f in self.diagnosis.failures[:REMAINING]]
        if self.run_errors:              # per run: a step may help the set, hurt some runs
            d["runs"] = self.run_errors
        d["refused"] = self.refused
        d["worse"] = self.worse
        return d


#: A run's energy-loss error is made worse when its magnitude grows by more than this
#: many percentage points and by more than ``WORSE_RATIO`` (the page's rule, modelplots.js).
WORSE_POINTS = 2.0
WORSE_RATIO = 1.5


def run_errors(ev: Evaluation) -> list[dict[str, Any]]:
    """Each run's energy-loss and stiffness error (%) of an evaluation with figures
    (none for a kind without energy figures: FRFs, backbones)."""
    out = [{"run": r.name, "energy_loss_error_pct": r.energy_loss_error_pct,
            "stiffness_error_pct": r.stiffness_error_pct} for r in ev.runs]
    return out if any(np.isfinite(r["energy_loss_error_pct"]) for r in out) else []


def worsened(before: list[dict[str, Any]], after: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Runs whose energy-loss error the step makes worse: [{run, before_pct, after_pct}]."""
    prev = {r["run"]: r["energy_loss_error_pct"] for r in before}
    out = []
    for r in after:
        a, b = prev.get(r["run"]), r["energy_loss_error_pct"]
        if a is None or not (np.isfinite(a) and np.isfinite(b)):
            continue
        if abs(b) > abs(a) + WORSE_POINTS and abs(b) > WORSE_RATIO * abs(a):
            out.append({"run": r["run"], "before_pct": float(a), "after_pct": float(b)})
    return out


def describe_worse(effect: str, worse: list[dict[str, Any]]) -> str:
    """One phrase: + effect would make these runs' energy-loss error worse (a -> b %)."""
    runs = ", ".join(f"{w['run']} ({w['before_pct']:+.1f} % -> {w['after_pct']:+.1f} %)"
                     for w in worse)
    return f"+ {effect} makes the energy-loss error worse on {runs}"


@dataclass
class Ladder:
    """Successive models and the noise floor they are judged against."""

    start: str
    steps: list[LadderStep]
    noise_floor: float
    noise_floor_validation: float
    adequate: bool
    stop_reason: str
    runs: list[str]
    fit_runs: list[str]
    validation_runs: list[str]
    split_rule: str
    auto: bool
    factor: float

    @property
    def key(self) -> str:
        """Stable id of the ladder's question: runs, start model, mode and split."""
        text = json.dumps([sorted(self.runs), self.start, self.auto, sorted(self.validation_runs)])
        return hashlib.sha1(text.encode()).hexdigest()[:12]

    def to_dict(self, full: bool = False) -> dict[str, Any]:
        d = {"steps": [s.to_dict() for s in self.steps], "noise_floor": self.noise_floor,
             "adequate": self.adequate, "start": self.start, "final_model": self.steps[-1].model,
             "stop_reason": self.stop_reason, "noise_floor_validation": self.noise_floor_validation,
             "factor": self.factor, "auto": self.auto, "key": self.key, "runs": self.runs,
             "fit_runs": self.fit_runs, "validation_runs": self.validation_runs,
             "split": self.split_rule}
        if full and self.steps[-1].diagnosis is not None:
            d["final_diagnosis"] = self.steps[-1].diagnosis.to_dict(full=True)
        return d


def _summary(dg: Diagnosis) -> list[dict[str, Any]]:
    return [{"effect": c.effect, "nrmse_after": c.nrmse_after,
             "nrmse_after_validation": c.nrmse_after_validation, "significant": c.significant}
            for c in dg.candidates]


def _step(dg: Diagnosis, added: str | None) -> LadderStep:
    best = dg.candidates[0] if dg.candidates else None
    tie = ({"effects": [best.effect, *best.tie_with], "reason": best.tie_reason}
           if best is not None and best.tie_with else None)
    return LadderStep(dg.model.expr, added, dg.nrmse, dg.nrmse_validation, dg.adequate,
                      parameters_dict(dg.base), dg.verdict, tie, _summary(dg), dg,
                      run_errors=run_errors(dg.evaluation))


def _next(dg: Diagnosis, step: LadderStep, runs: Sequence[Measurement]
          ) -> CandidateResult | None:
    """The best significant candidate that makes no run's energy loss worse; the ones
    refused on the way are recorded in ``step.refused``."""
    if not step.run_errors:
        return dg.best                    # a kind without energy figures (FRF, backbone)
    for cand in (c for c in dg.candidates if c.significant):
        worse = worsened(step.run_errors,
                         run_errors(evaluate(cand.fit.model, cand.fit.params_, runs)))
        if not worse:
            return cand
        step.refused.append({"effect": cand.effect, "runs": worse,
                             "reason": describe_worse(cand.effect, worse)})
    return None


def prefixes(expr: str | Model) -> list[Model]:
    """Valid models made of the first 1, 2, ... effects of ``expr``."""
    model = Model.parse(expr)
    out = []
    for k in range(1, len(model.names) + 1):
        try:
            out.append(Model.parse("+".join(model.names[:k])))
        except InputError:
            continue
    return out


def build_ladder(runs: Sequence[Measurement], model: Model | str, *, max_steps: int | None = None,
                 auto: bool = True, validate: Sequence[str] | None = None,
                 settings: DiagnoseSettings = DiagnoseSettings(),
                 progress: Callable[[str], None] | None = None) -> Ladder:
    """The ladder from ``model`` (module docstring)."""
    model = Model.parse(model)
    if max_steps is not None and (isinstance(max_steps, bool) or int(max_steps) < 0):
        raise InputError(f"must be a whole number >= 0, got {max_steps!r}", field="max_steps")
    fit_r, val_r, rule = split_by_names(runs, validate) if validate else kind_of(runs).split(runs)
    runs = judged_runs(runs, fit_r, val_r)
    val_names = [r.name for r in val_r]
    noise = noise_floor(runs)
    floor_fit = noise.over(runs, [r.name for r in fit_r])
    steps: list[LadderStep] = []
    if auto:
        fit: FitResult | None = None
        current, added = model, None
        while True:
            dg = diagnose_prepared(runs, current, validate=val_names, settings=settings,
                                   base_fit=fit, noise=noise, progress=progress)
            steps.append(_step(dg, added))
            if progress:
                progress(f"step {len(steps)}: {current.expr} NRMSE {dg.nrmse:.4g}")
            if dg.adequate:
                stop = "adequate"
                break
            best = _next(dg, steps[-1], runs)
            if best is None:
                stop = dg.verdict if not steps[-1].refused else (
                    "no candidate taken: " + "; ".join(r["reason"] for r in steps[-1].refused))
                break
            if max_steps is not None and len(steps) - 1 >= int(max_steps):
                stop = f"max_steps ({max_steps}) reached; next would be + {best.effect}"
                break
            current, fit, added = best.fit.model, best.fit, best.effect
    else:
        fit = None
        chain = prefixes(model)
        for i, m in enumerate(chain):
            last = i == len(chain) - 1
            own = getattr(kind_of(runs), "fit", None)
            fit = own(m, fit_r, val_r, init=fit) if own is not None else ModelFitter(
                m, multistart=settings.multistart, seed=settings.seed).fit(
                [r.data for r in fit_r], validation=[r.data for r in val_r], init=fit,
                floor=floor_fit)
            added = None if i == 0 else next(n for n in m.names if n not in chain[i - 1].names)
            if last:
                dg = diagnose_prepared(runs, m, validate=val_names, settings=settings,
                                       base_fit=fit, noise=noise, progress=progress)
                steps.append(_step(dg, added))
            else:
                ev = evaluate(m, fit.params_, runs, loops=runs[0].kind in ("sine", "record"))
                steps.append(LadderStep(m.expr, added, ev.nrmse(), ev.nrmse(val_names),
                                        ev.nrmse() <= settings.factor * noise.nrmse,
                                        parameters_dict(fit), run_errors=run_errors(ev)))
            if i:                 # the user asked for this step: taken, and flagged
                steps[-1].worse = worsened(steps[-2].run_errors, steps[-1].run_errors)
        stop = "end of the given expression"
        flagged = [describe_worse(s.added or s.model, s.worse) for s in steps if s.worse]
        if flagged:
            stop += "; " + "; ".join(flagged)
    final = steps[-1]
    floor_val = noise.over(runs, val_names)
    return Ladder(model.expr, steps, noise.nrmse, floor_val, final.adequate, stop,
                  [r.name for r in runs], [r.name for r in fit_r], val_names, rule, auto,
                  settings.factor)
