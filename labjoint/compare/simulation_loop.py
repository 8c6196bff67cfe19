"""Which effect is missing, by simulation error: diagnose and ladder for forward prediction.

The loop of :mod:`labjoint.compare.diagnosis` with the displacement simulated from the
applied force (:mod:`labjoint.compare.output_error`) as the prediction:

1. Split (the record kind's rule, :meth:`RecordKind.split`): with two or more records,
   every 3rd by rms displacement validates; one record validates on its last third, the
   model still simulated along the whole history from rest.
2. Fit the model by simulation error on the fit parts; simulate the validation parts.
3. Refit model + effect for every simulable candidate (:data:`SUPPORTED` of
   :mod:`labjoint.models.simulate`; the others are listed as skipped), started from the
   equation-error fit of the extended model with the baseline's optimum for the
   baseline's parameters; judge each on the validation parts with the stated test of
   :mod:`labjoint.compare.significance`: the one-sided paired t-test of the squared
   displacement residual summed per unit (the record's periods or blocks; with fewer than
   ``MIN_TEST_UNITS`` on the validation parts, each is cut into equal blocks until there
   are, the residual of a deterministic model error repeating block after block).
4. Adequate: simulation NRMSE <= ``factor`` x the noise floor (the displacement noise of
   the records over their rms displacement) and no significant candidate.

The ladder adds the best significant candidate, refits, and diagnoses again until the
model is adequate, nothing significant is left, or ``max_steps`` effects were added.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.compare.candidates import candidate_effects, candidate_model
from labjoint.compare.describe import pct_text
from labjoint.compare.kinds import KINDS
from labjoint.compare.kinds.record import RecordMeasurement
from labjoint.compare.output_error import (Prediction, SimulationFit, displacement_floor,
                                           fit_prepared, prepare_records)
from labjoint.compare.runs import split_by_names
from labjoint.compare.significance import (PairedTest, SignificanceSettings, is_significant,
                                           paired_test)
from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.models.simulate import DEFAULT_SUBSTEPS, SUPPORTED, check_simulable

MIN_TEST_UNITS = 16
DEFAULT_FACTOR = 1.5


def unit_sse(preds: Sequence[Prediction], spans: Sequence[np.ndarray]) -> np.ndarray:
    """Squared residual summed per unit of every prediction (module docstring, step 3)."""
    cuts = []
    for p, sp in zip(preds, spans):
        r2 = np.where(p.judged, (p.measured - p.predicted) ** 2, 0.0)
        units = [(int(a), int(b)) for a, b in sp if p.judged[int(a):int(b)].any()]
        cuts.append((r2, units))
    n_units = sum(len(u) for _, u in cuts)
    split = max(1, int(np.ceil(MIN_TEST_UNITS / max(n_units, 1))))
    out = []
    for r2, units in cuts:
        for a, b in units:
            edges = np.linspace(a, b, split + 1).round().astype(int)
            out.extend(float(r2[e0:e1].sum()) for e0, e1 in zip(edges[:-1], edges[1:]) if e1 > e0)
    return np.array(out)


@dataclass
class SimCandidate:
    """One candidate effect refitted by simulation error and judged on the validation parts."""

    effect: str
    fit: SimulationFit
    test: PairedTest
    significant: bool
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return {"effect": self.effect, "model": self.fit.model.expr, "nrmse_after": self.fit.nrmse(),
                "nrmse_after_validation": self.fit.nrmse("validation"),
                "significant": self.significant, "p_value": self.test.p, "reason": self.reason,
                "parameters": self.fit.model_dict()["parameters"],
                "asymmetry": self.fit.asymmetry()}


@dataclass
class SimulationDiagnosis:
    """A diagnosis by simulation error (module docstring)."""

    model: Model
    base: SimulationFit
    noise_floor: float
    floor_validation: float
    rule: str
    candidates: list[SimCandidate]
    skipped: list[dict[str, str]]
    adequate: bool
    verdict: str
    failures: list[dict[str, str]]
    timing: dict[str, float] = field(default_factory=dict)

    @property
    def best(self) -> SimCandidate | None:
        return next((c for c in self.candidates if c.significant), None)

    def to_dict(self) -> dict[str, Any]:
        return {"measurement": "record", "error": "simulation", "model": self.model.expr,
                "nrmse": self.base.nrmse(), "nrmse_validation": self.base.nrmse("validation"),
                "noise_floor": self.noise_floor, "noise_floor_validation": self.floor_validation,
                "adequate": self.adequate, "verdict": self.verdict, "split": self.rule,
                "fit_runs": [p.name for p in self.base.fit],
                "validation_runs": [p.name for p in self.base.validation],
                "parameters": self.base.model_dict()["parameters"],
                "flags": self.base.flags(), "asymmetry": self.base.asymmetry(),
                **({"measurement_flags": self.base.measurement_flags} if self.base.measurement_flags else {}),
                "failures": self.failures,
                "candidates": [c.to_dict() for c in self.candidates], "skipped": self.skipped,
                "timing_s": self.timing}


def prepare_split(runs: Any, validate: Sequence[Any] | None = None, *, periodic: bool = False,
                  warmup: str | float = "auto") -> tuple[list[RecordMeasurement],
                                                         list[RecordMeasurement], str]:
    """Records prepared as the record kind and split into fit and validation parts."""
    items = [runs] if isinstance(runs, (str, Path)) else list(runs)
    recs = prepare_records(items + list(validate or []), periodic=periodic, warmup=warmup)
    if validate:
        fit_r, val_r, rule = split_by_names(recs, [m.name for m in recs[len(items):]])
    else:
        fit_r, val_r, rule = KINDS["record"].split(recs)
    return list(fit_r), list(val_r), rule


def _ordinal(i: int) -> str:
    return f"{i}{'th' if 10 <= i % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(i % 10, 'th')}"


def _failures(base: SimulationFit, recs: Sequence[RecordMeasurement], floor: float,
              factor: float) -> list[dict[str, str]]:
    """Where the simulation fails: the error against the noise, over time (the worst
    eighth of the judged record) and over frequency (the share of the residual's power on
    the lines the force excites and off them: off them is nonlinear distortion the model
    does not produce)."""
    out = []
    n = base.nrmse()
    ratio = n / floor if floor > 0 else float("inf")
    out.append({"where": "overall", "text": (
        f"the simulated displacement misses the measured one by NRMSE {pct_text(n)}, "
        f"{ratio:.3g}x the noise floor {pct_text(floor)}"
        + (" (within the adequacy factor)" if ratio <= factor else ""))})
    for p, m in zip(base.fit, recs):
        r = np.where(p.judged, p.measured - p.predicted, 0.0)
        j = np.flatnonzero(p.judged)
        if j.size < 16:
            continue
        seg = r[j[0]:j[-1] + 1]
        blocks = np.array_split(seg, min(8, seg.size // 2))
        rms = [float(np.sqrt(np.mean(b ** 2))) for b in blocks]
        worst = int(np.argmax(rms))
        out.append({"where": f"time ({p.name})", "text": (
            f"the residual is largest in the {_ordinal(worst + 1)} of {len(blocks)} equal "
            f"parts of the judged record (rms {rms[worst]:.3g} m against "
            f"{float(np.median(rms)):.3g} m in the median part)")})
        per = m.excitation.period_s
        n_per = int(round(per * m.fs)) if per else 0
        k = (j[-1] + 1 - j[0]) // n_per if n_per else 0
        if k < 1 or abs(per * m.fs - n_per) > 1e-6 * n_per:
            continue                # lines need whole periods of a periodic excitation
        span = slice(int(j[0]), int(j[0]) + k * n_per)
        spec = np.abs(np.fft.rfft(r[span])) ** 2
        f = m.data.force[span]
        fp = np.abs(np.fft.rfft(f - f.mean())) ** 2
        excited = fp > 1e-6 * fp.max()
        share = float(spec[excited].sum() / max(spec.sum(), 1e-300))
        out.append({"where": f"frequency ({p.name})", "text": (
            f"{100 * share:.3g} % of the residual power lies on the {int(excited.sum())} "
            f"lines the force excites, {100 * (1 - share):.3g} % off them"
            + ("; the model misses distortion the joint adds off the excited lines"
               if share < 0.5 else ""))})
    return out


def diagnose_simulation(runs: Any, model: str | Model, *, validate: Sequence[Any] | None = None,
                        candidates: Sequence[str] | str | None = None, periodic: bool = False,
                        substeps: int = DEFAULT_SUBSTEPS, warmup: str | float = "auto",
                        factor: float = DEFAULT_FACTOR,
                        significance: SignificanceSettings = SignificanceSettings(),
                        seed: int = 0, base: SimulationFit | None = None,
                        start: dict[str, float] | None = None,
                        bounds: dict[str, tuple[float, float]] | None = None,
                        split: tuple[list[RecordMeasurement], list[RecordMeasurement], str] | None = None,
                        progress: Callable[[str], None] | None = None) -> SimulationDiagnosis:
    """Diagnose ``model`` by simulation error (module docstring)."""
    model = Model.parse(model)
    check_simulable(model)
    t0 = time.perf_counter()
    fit_r, val_r, rule = split or prepare_split(runs, validate, periodic=periodic, warmup=warmup)
    if base is None:
        base = fit_prepared(fit_r, model, validation=val_r, periodic=periodic,
                            substeps=substeps, seed=seed, start=start, bounds=bounds)
    if progress:
        progress(f"fitted {model.expr} by simulation")
    floor, floor_val = displacement_floor(base.fit), displacement_floor(base.validation)
    spans = [m.units() for m in val_r]
    base_units = unit_sse(base.validation, spans)
    only = candidates.split(",") if isinstance(candidates, str) else candidates
    names, not_applicable = candidate_effects(model, only)
    simulable = [n for n in names if n in SUPPORTED]
    skipped = [{"effect": n, "reason": r} for n, r in not_applicable.items()] + [
        {"effect": n, "reason": "not in the forward simulator's laws"}
        for n in names if n not in SUPPORTED]
    n_val = base.nrmse("validation")
    quiet = base.nrmse() <= factor * floor and n_val <= floor_val
    t1 = time.perf_counter()
    cands = []
    for name in ([] if quiet else simulable):
        ext = candidate_model(model, name)
        try:
            fit = fit_prepared(fit_r, ext, validation=val_r, periodic=periodic,
                               substeps=substeps, seed=seed, warm=base.params)
        except InputError as exc:
            skipped.append({"effect": name, "reason": exc.message})
            continue
        test = paired_test(base_units, unit_sse(fit.validation, spans))
        sig, reason = is_significant(test, n_val, fit.nrmse("validation"), floor_val, significance)
        cands.append(SimCandidate(name, fit, test, sig, reason))
        if progress:
            progress(f"tried {name}")
    cands.sort(key=lambda c: (not c.significant, c.fit.nrmse("validation")))
    best = next((c for c in cands if c.significant), None)
    near = base.nrmse() <= factor * floor
    adequate = near and best is None
    ratio = base.nrmse() / floor if floor > 0 else float("inf")
    if quiet:
        verdict = (f"adequate: the validation simulation NRMSE {pct_text(n_val)} is at or below "
                   f"the validation noise floor {pct_text(floor_val)} (no candidate fitted)")
    elif adequate:
        verdict = (f"adequate: simulation NRMSE {pct_text(base.nrmse())} is {ratio:.3g}x the "
                   f"noise floor (<= {factor:g}x) and no candidate improves it significantly")
    elif best is not None:
        verdict = (f"add {best.effect}: validation simulation NRMSE {pct_text(n_val)} -> "
                   f"{pct_text(best.fit.nrmse('validation'))}")
    else:
        verdict = (f"structure remains that no simulable effect explains: simulation NRMSE "
                   f"{pct_text(base.nrmse())} is {ratio:.3g}x the noise floor and none of the "
                   f"{len(cands)} tried improves it significantly")
    t2 = time.perf_counter()
    return SimulationDiagnosis(model, base, floor, floor_val, rule, cands, skipped, adequate,
                               verdict, _failures(base, fit_r, floor, factor),
                               {"base_fit": t1 - t0, "candidates": t2 - t1, "total": t2 - t0})


def ladder_simulation(runs: Any, model: str | Model, *, max_steps: int | None = None,
                      validate: Sequence[Any] | None = None, periodic: bool = False,
                      warmup: str | float = "auto", progress: Callable[[str], None] | None = None,
                      **options: Any) -> dict[str, Any]:
    """Add the best significant effect until adequate (module docstring)."""
    split = prepare_split(runs, validate, periodic=periodic, warmup=warmup)
    model = Model.parse(model)
    steps: list[dict[str, Any]] = []
    added: str | None = None
    base: SimulationFit | None = None
    while True:
        d = diagnose_simulation(None, model, periodic=periodic, split=split, base=base,
                                progress=progress, **options)
        steps.append({"added": added, "model": model.expr, "nrmse": d.base.nrmse(),
                      "nrmse_validation": d.base.nrmse("validation"),
                      "noise_floor": d.noise_floor, "adequate": d.adequate,
                      "verdict": d.verdict, "parameters": d.base.model_dict()["parameters"]})
        best = d.best
        if d.adequate:
            reason = "adequate"
        elif best is None:
            reason = "no candidate improves the simulation significantly"
        elif max_steps is not None and len(steps) > max_steps:
            reason = f"max_steps = {max_steps} reached"
        else:
            model, added, base = best.fit.model, best.effect, best.fit
            continue
        return {"measurement": "record", "error": "simulation", "noise_floor": d.noise_floor,
                "adequate": d.adequate, "stop_reason": reason, "split": d.rule, "steps": steps,
                "final": d.to_dict(),
                **({"measurement_flags": d.base.measurement_flags} if d.base.measurement_flags else {})}
