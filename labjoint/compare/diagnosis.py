"""Which effect is missing: refit the model with each candidate effect, judge on held-out runs.

1. Split the runs: fit runs and validation runs (:func:`labjoint.compare.runs.default_split`
   or named ones).
2. Fit the model on the fit runs; evaluate it on all runs; the noise floor of all runs and
   of the validation runs (:mod:`labjoint.compare.noise`); where it fails
   (:mod:`labjoint.compare.residuals`, :mod:`labjoint.compare.describe`).
3. Refit model + effect for every candidate (:mod:`labjoint.compare.candidates`), judge
   each on the validation runs with the stated test (:mod:`labjoint.compare.significance`),
   rank by validation NRMSE; refit the contenders from scratch as well (:func:`contenders`:
   cheap ones within 1.5x of the best, costly ones only among the ``refine`` best; none
   when the baseline is already at the noise floor on the validation runs), keeping the
   better fit; judge the significant ones again against the baseline refitted from their
   optimum without them (an ablation: the gain must come from the effect, not from moving
   the baseline's own parameters); flag ties, attach evidence and explanation
   (:mod:`labjoint.compare.evidence`).
4. Adequate: pooled NRMSE <= ``factor`` x noise floor (default 1.5) and no significant
   candidate. When the baseline is already within ``QUIET_SHARE`` of the significance
   test's ``min_rel`` of the noise floor of the validation runs (and within the factor
   overall), no candidate is fitted: on data it was not fitted on, nothing does better
   than the noise, so no effect could gain the ``min_rel`` x floor a significant one
   must; the model is adequate and the diagnosis says so at the cost of one fit. Otherwise the verdict names the best significant candidate, or says that
   structure remains that no known effect explains (only when every registered candidate
   that applies was tried; else that the missing effect is not among the N tried).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from labjoint.compare.candidates import (ablate, candidate_effects, candidate_model, refine,
                                         refit_candidates)
from labjoint.compare.diagnosis_result import (CandidateResult, DiagnoseSettings, Diagnosis,  # noqa: F401
                                               fit_asymmetry, parameters_dict)
from labjoint.compare.evidence import explanation
from labjoint.compare.kinds import kind_of
from labjoint.compare.measurement import Kind, Measurement, NoiseFloor, noise_floor
from labjoint.compare.metrics import Evaluation, evaluate
from labjoint.compare.runs import split_by_names
from labjoint.compare.significance import SignificanceSettings, is_significant, noise_test
from labjoint.compare.ties import mark_ties, simpler_first
from labjoint.errors import InputError
from labjoint.models import FitResult, Model, ModelFitter
from labjoint.models.effects import get_effect

CONTENDER_RATIO = 1.5
#: no candidate is fitted within this share of ``min_rel`` above the validation floor
QUIET_SHARE = 0.5


def unexplained(model: Model, tried: Sequence[str]) -> str:
    """What a diagnosis that found no significant candidate may claim: that no known
    effect explains the residual only once every registered candidate that applies to
    ``model`` was tried; otherwise only that the missing effect is not among those tried.

    >>> m = Model.parse("linear_stiffness")
    >>> unexplained(m, ["offset", "inertia"])
    'structure remains: the missing effect is not among the 2 tried (offset, inertia; 13 registered effects not tried)'
    >>> unexplained(m, candidate_effects(m)[0])
    'structure remains that no known effect explains'
    """
    missing = [n for n in candidate_effects(model)[0] if n not in set(tried)]
    if not missing:
        return "structure remains that no known effect explains"
    return (f"structure remains: the missing effect is not among the {len(tried)} tried "
            f"({', '.join(tried) or 'none'}; {len(missing)} registered effects not tried)")


@dataclass(frozen=True, eq=False)
class Baseline:
    """What candidates are judged against: the baseline evaluated on every measurement,
    its residual maps, the validation measurements and their noise floor, the test."""

    kind: Kind
    runs: Sequence[Measurement]
    evaluation: Evaluation
    maps: Any
    validation: list[str]
    floor: float
    significance: SignificanceSettings

    def judge(self, name: str, fit: FitResult, ablated: Evaluation | None = None
              ) -> CandidateResult:
        """Judge a candidate on the validation runs against the baseline, or against the
        baseline refitted from the candidate's optimum (``ablated``) where that validates
        better."""
        val, base_ev = self.validation, self.evaluation
        ev = evaluate(fit.model, fit.params_, self.runs, loops=False)
        ref = base_ev
        if ablated is not None and ablated.nrmse(val) < base_ev.nrmse(val):
            ref = ablated
        rv, cv = ref.subset(val), ev.subset(val)
        dforce = sum(float(np.sum((c.model_force - r.model_force)[r.run.data.steady] ** 2))
                     for r, c in zip(rv, cv))
        n_samples = sum(int(np.count_nonzero(r.run.data.steady)) for r in rv)
        noise_var = self.floor ** 2 * sum(r.ssf for r in rv) / max(n_samples, 1)
        test = noise_test(np.concatenate([r.unit_sse() for r in rv]),
                          np.concatenate([r.unit_sse() for r in cv]), dforce, noise_var,
                          known=bool(getattr(self.kind, "known_noise", False)))
        nv_base, nv = ref.nrmse(val), ev.nrmse(val)
        sig, reason = is_significant(test, nv_base, nv, self.floor, self.significance)
        maps = self.kind.maps(ev.runs, {})
        against = "" if ref is base_ev else " (against the baseline refitted from its optimum)"
        val_txt = (f"validation NRMSE {100 * nv_base:.3g} % -> {100 * nv:.3g} %{against} (noise "
                   f"floor {100 * self.floor:.3g} %), {reason}")
        asym = fit_asymmetry(fit, self.runs)
        words = "; ".join(a["text"] for a in asym)
        evid = self.kind.evidence(name, base_ev, ev, self.maps, maps, fit, val_txt)
        return CandidateResult(name, fit, ev, ev.nrmse(), nv, test, sig, reason,
                               f"{evid}; {words}" if words else evid, explanation(name),
                               asymmetry=asym)


def judged_runs(runs: Sequence[Measurement], fit_r: Sequence[Measurement],
                val_r: Sequence[Measurement]) -> list[Measurement]:
    """The measurements a diagnosis evaluates: ``runs``, or the fit and validation parts
    when the split made parts (one record split in time)."""
    if {r.name for r in runs} == {r.name for r in (*fit_r, *val_r)}:
        return list(runs)
    return [*fit_r, *val_r]


def contenders(cands: list[CandidateResult], base_validation: float, n: int) -> list[str]:
    """The candidates worth refitting from scratch (:func:`.candidates.refine`): those that
    improve on the baseline and come within ``CONTENDER_RATIO`` of the best (a fresh start
    moves a fit by a fraction of its error, so one far behind cannot overtake the best);
    of the costly ones (hysteretic, modifier: each evaluation integrates a slip law, and a
    cold multi-start fit of two slip laws side by side takes minutes) only those among the
    ``n`` best. A warm start can leave a cheap candidate short of its optimum by more than
    the tie tolerance, so every cheap contender is refined. Nothing is refined when the
    baseline is already within the adequacy factor of the noise floor on the validation
    runs (:func:`diagnose_prepared`): what a fresh start could add there is noise."""
    ranked = sorted(cands, key=lambda c: c.nrmse_after_validation)
    if not ranked:
        return []
    best = ranked[0].nrmse_after_validation
    out = []
    for i, c in enumerate(ranked):
        if not (c.nrmse_after_validation < base_validation
                and c.nrmse_after_validation <= CONTENDER_RATIO * best):
            continue
        costly = get_effect(c.effect).kind in ("hysteretic", "modifier")
        if i < n or not costly:
            out.append(c.effect)
    return out


def own_refits(own: Callable[..., FitResult], base_fit: FitResult, model: Model,
               names: Sequence[str], fit_r: Sequence[Measurement], val_r: Sequence[Measurement],
               progress: Callable[[str], None] | None) -> dict[str, FitResult]:
    """Candidates refitted by a kind's own fitter, each from the baseline's optimum."""
    out = {}
    for n in names:
        out[n] = own(candidate_model(model, n), fit_r, val_r, init=base_fit)
        if progress:
            progress(n)
    return out


def diagnose_prepared(runs: Sequence[Measurement], model: Model | str, *,
                      validate: Sequence[str] | None = None,
                      settings: DiagnoseSettings = DiagnoseSettings(),
                      base_fit: FitResult | None = None, noise: NoiseFloor | None = None,
                      progress: Callable[[str], None] | None = None) -> Diagnosis:
    """Diagnose ``model`` on prepared runs (module docstring)."""
    model = Model.parse(model)
    kind = kind_of(runs)
    t0 = time.perf_counter()
    fit_r, val_r, rule = split_by_names(runs, validate) if validate else kind.split(runs)
    if not val_r:
        raise InputError(f"a diagnosis judges every candidate on records it did not fit, and the "
                         f"split left none ({rule}): give two or more records, or --validate",
                         field="runs")
    runs = judged_runs(runs, fit_r, val_r)
    fit_names, val_names = [r.name for r in fit_r], [r.name for r in val_r]
    noise = noise or noise_floor(runs)
    floor_fit = noise.over(runs, fit_names)
    own = getattr(kind, "fit", None)      # a kind with its own predictor fits its own way
    if base_fit is None and own is not None:
        base_fit = own(model, fit_r, val_r)
    elif base_fit is None:
        base_fit = ModelFitter(model, multistart=settings.multistart, seed=settings.seed).fit(
            [r.data for r in fit_r], validation=[r.data for r in val_r],
            floor=floor_fit)
    t1 = time.perf_counter()
    if progress:
        progress(f"fitted {model.expr}")
    ev = evaluate(model, base_fit.params_, runs)
    floor_val = noise.over(runs, val_names)
    maps = kind.maps(ev.runs, noise.by_run())
    curves = kind.curves(ev.runs)
    found = kind.failures(ev, maps, curves, noise.nrmse, settings.factor)
    names, skipped = (kind.candidates(model, settings.candidates) if hasattr(kind, "candidates")
                      else candidate_effects(model, settings.candidates))
    near = ev.nrmse() <= settings.factor * noise.nrmse
    quiet = near and ev.nrmse(val_names) <= (1 + QUIET_SHARE * settings.significance.min_rel) * floor_val
    if quiet:
        names = []
    if own is not None:
        fits = own_refits(own, base_fit, model, names, fit_r, val_r, progress)
    else:
        fits = refit_candidates(base_fit, model, names, [r.data for r in fit_r],
                                [r.data for r in val_r], warm=settings.warm,
                                n_jobs=settings.n_jobs, multistart=settings.multistart,
                                seed=settings.seed, progress=progress, floor=floor_fit,
                                executor=settings.executor)
    sig_s = settings.significance
    judge = Baseline(kind, runs, ev, maps, val_names, floor_val, sig_s).judge
    cands = [judge(n, fits[n]) for n in names]
    cands.sort(key=lambda c: c.nrmse_after_validation)
    at_floor = ev.nrmse(val_names) <= settings.factor * floor_val
    top = contenders(cands, ev.nrmse(val_names), settings.refine) \
        if settings.warm and not at_floor and own is None else []
    fd, vd = [r.data for r in fit_r], [r.data for r in val_r]
    if top:
        better = refine(fits, top, fd, vd, n_jobs=settings.n_jobs, seed=settings.seed,
                        executor=settings.executor)
        for i, c in enumerate(cands):
            if c.effect in top and better[c.effect] is not fits[c.effect]:
                cands[i] = judge(c.effect, better[c.effect])
    for i, c in enumerate(cands):
        if c.significant:
            ab = (ablate(c.fit, model, fd, vd, settings.seed) if own is None else
                  own(model, fit_r, val_r, init={k: v for k, v in c.fit.params_.valuesdict().items()
                                                 if k in set(model.param_names)}))
            cands[i] = judge(c.effect, c.fit, evaluate(model, ab.params_, runs, loops=False))
    cands.sort(key=lambda c: c.nrmse_after_validation)
    t2 = time.perf_counter()
    mark_ties(cands, ev, val_names, floor_val, sig_s, known=bool(getattr(kind, "known_noise", False)))
    cands.sort(key=lambda c: (not c.significant, c.nrmse_after_validation))
    cands = simpler_first(cands)
    best = next((c for c in cands if c.significant), None)
    adequate = near and best is None
    ratio = ev.nrmse() / noise.nrmse if noise.nrmse > 0 else float("inf")
    if quiet:
        verdict = (f"adequate: the validation NRMSE {100 * ev.nrmse(val_names):.3g} % is "
                   f"within {100 * QUIET_SHARE * settings.significance.min_rel:.3g} % of the validation "
                   f"runs' noise floor {100 * floor_val:.3g} %, less than the significance test "
                   "asks any effect to gain (no candidate fitted)")
    elif adequate:
        verdict = (f"adequate: NRMSE {100 * ev.nrmse():.3g} % is {ratio:.3g}x the noise floor "
                   f"(<= {settings.factor:g}x) and no candidate improves it significantly")
    elif best is not None:
        tie = f" (tied with {', '.join(best.tie_with)}: {best.tie_reason})" if best.tie_with else ""
        verdict = (f"add {best.effect}: validation NRMSE {100 * ev.nrmse(val_names):.3g} % -> "
                   f"{100 * best.nrmse_after_validation:.3g} %{tie}")
    else:     # a kind may know that its data were too coarse to decide (frf: issue 32)
        weak = getattr(kind, "inconclusive", lambda *a: None)(cands, ev.nrmse(val_names), fit_r, val_r)
        verdict = weak or (f"{unexplained(model, names)}: NRMSE {100 * ev.nrmse():.3g} % is "
                           f"{ratio:.3g}x the noise floor and no candidate improves it significantly")
    t3 = time.perf_counter()
    return Diagnosis(model, base_fit, ev, noise, floor_val, fit_names, val_names, rule, maps,
                     curves, found, cands, skipped, adequate, verdict, settings,
                     {"base_fit": t1 - t0, "candidates": t2 - t1, "rest": t3 - t2,
                      "total": t3 - t0})
