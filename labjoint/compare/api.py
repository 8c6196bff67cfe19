"""The functions the CLI and the REST service call: fit, diagnose, ladder on runs.

Each takes runs (run-file or CSV paths, :class:`~labjoint.storage.Run` objects or prepared
runs) and a model expression, and returns the JSON-able dict of the CLI contract
(design.md, model-comparison issue). ``full=True`` adds what the web page draws: residual
maps, physics curves, measured-versus-model loops (``loops``: per run, the mean steady
cycle of displacement, measured and model force; for a ladder in its
``final_diagnosis``), the noise floor per run. The ``*_report``
functions return the richer objects themselves.

Options (keyword arguments, also the REST ``options``): ``validate`` (runs to judge on,
names or paths; default: hold out the highest frequency, or every 3rd run by amplitude
with one frequency), ``prime_cycles`` ("auto" or a number), ``multistart``, ``seed``,
``factor`` (adequacy factor on the noise floor, default 1.5), ``alpha``, ``practical``,
``min_rel``, ``tie_tol``, ``tie_corr`` (:mod:`.significance`), ``n_jobs`` (candidate
refits in parallel), ``executor`` (candidate refits on it instead, e.g. a Dask cluster's),
``candidates`` (restrict the effects tried), ``warm`` (False: the naive serial refit from
scratch), ``max_steps``, ``auto``, ``save`` (ladder).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from labjoint.compare.backbone_api import is_backbone, load_structural
from labjoint.compare.frf_api import FRF_OPTIONS, is_frfset, load_frf, save_beside
from labjoint.compare.diagnosis import (DiagnoseSettings, Diagnosis, diagnose_prepared,
                                       fit_asymmetry, parameters_dict)
from labjoint.compare.jsonsafe import clean
from labjoint.compare.ladders import Ladder, build_ladder
from labjoint.compare.metrics import Evaluation, evaluate
from labjoint.compare.measurement import Measurement, NoiseFloor, noise_floor
from labjoint.compare.modal_api import MODAL_OPTIONS, load_modal
from labjoint.compare.kinds import kind_of, prepare
from labjoint.compare.runs import split_by_names
from labjoint.compare.significance import SignificanceSettings
from labjoint.compare.store import save_ladder
from labjoint.compare.flags import measurement_flags
from labjoint.errors import InputError
from labjoint.identify.plausible import Plausibility
from labjoint.models import FitResult, Model, ModelFitter

SIG_KEYS = ("alpha", "practical", "min_rel", "tie_tol", "tie_corr")


def load(runs: Any, validate: Sequence[Any] | None = None, prime_cycles: int | str = "auto",
         kind: str = "auto", warmup: str | float = "auto", frf: dict[str, Any] | None = None,
         plausibility: Plausibility | None = None) -> tuple[list[Measurement], list[str] | None]:
    """Prepared measurements of one kind (:func:`labjoint.compare.kinds.prepare`;
    validation runs named but not among ``runs`` are added) and the validation run names.
    FRF set files (or FrfSets) are prepared as the ``frf`` kind inside the structure of
    ``frf`` (the options of :mod:`labjoint.compare.frf_api`); backbone files (or
    Backbones) as the ``backbone`` kind on the same structure, judged together with FRF
    sets given beside them (:mod:`labjoint.compare.backbone_api`)."""
    if isinstance(runs, (str, Path)) or not isinstance(runs, Iterable):
        runs = [runs]
    items = list(runs)
    if not items:
        raise InputError("no runs given", field="runs")
    frf = {k: v for k, v in (frf or {}).items() if v is not None}
    if frf.get("modal") is not None or kind == "modal":
        return load_modal(items, validate, frf)
    for k in ("start", "bounds", "shaker", "drive_point", "modal_mass"):
        if frf.pop(k, None):
            raise InputError("goes with the modal kind (--modal)" + (" or --error simulation" if k in
                             ("start", "bounds") else ""), field=k)
    if frf.pop("between", None) is not None:
        raise InputError("names two sensors of the measured modes: it goes with --modal", field="between")
    if frf.pop("joint_shape", None):
        raise InputError("fits the participation of a joint between two sensors: it goes with "
                         "--modal and --between", field="joint_shape")
    frf.pop("responses", None)
    if any(is_backbone(x) for x in items):
        if kind not in ("auto", "frf", "backbone"):
            raise InputError(f"backbone files are the backbone kind, not {kind}", field="kind")
        return load_structural(items, validate, frf)
    if frf.get("linear_damping", "file") != "file":
        raise InputError("the linear damping is identified from measured backbones: give a backbone "
                         "file (labjoint backbone --out)", field="linear_damping")
    frf.pop("linear_damping", None)
    if any(is_frfset(x) for x in items) or (frf.get("structure") is not None and kind in ("auto", "frf")):
        if kind not in ("auto", "frf"):
            raise InputError(f"FRF sets are the frf kind, not {kind}", field="kind")
        return load_frf(items, validate, frf)
    if frf:
        raise InputError(f"{', '.join(sorted(frf))} go with FRF set files", field=sorted(frf)[0])
    extra = []
    if validate:
        given = {str(x) for x in items} | {str(Path(str(x)).resolve()) for x in items
                                          if isinstance(x, (str, Path))}
        extra = [v for v in validate if isinstance(v, (str, Path)) and Path(str(v)).is_file()
                 and str(Path(str(v)).resolve()) not in given and str(v) not in given]
    prepared = prepare(items + extra, kind=kind, prime_cycles=prime_cycles, warmup=warmup,
                       plausibility=plausibility)
    if not validate:
        return prepared, None
    _, val, _ = split_by_names(prepared, [str(v) for v in validate])
    return prepared, [r.name for r in val]


def _load(runs: Any, options: dict[str, Any]) -> tuple[list[Measurement], list[str] | None]:
    return load(runs, options.get("validate"), options.get("prime_cycles", "auto"),
                options.get("kind", "auto"), options.get("warmup", "auto"),
                {k: options.get(k) for k in (*FRF_OPTIONS, *MODAL_OPTIONS)},
                options.get("plausibility"))


def _measured(d: dict[str, Any], ms: Sequence[Measurement]) -> dict[str, Any]:
    """FRF and backbone results say what their NRMSE and noise floor are (design.md's
    ``measurement``); ``measurement_flags``: a user's likely mistakes in the data
    (:mod:`.flags`)."""
    flags = measurement_flags(ms)
    if flags:
        d["measurement_flags"] = flags
    kinds = {m.kind for m in ms}
    if kinds and kinds <= {"frf", "backbone"}:
        d["measurement"] = "+".join(k for k in ("frf", "backbone") if k in kinds)
        notes = {m.metadata.get("linear_damping") for m in ms if m.kind == "backbone"} - {None}
        if notes:
            d["linear_damping"] = notes.pop()
        d["error"] = " and ".join(
            {"frf": "response phasors (harmonics 1..H) whitened by the FRF set's response_std",
             "backbone": "frequency and damping ratio per amplitude whitened by the points' "
                         "standard uncertainties"}[k] for k in ("frf", "backbone") if k in kinds)
    if ms and ms[0].kind == "modal":
        d["measurement"] = "modal"
        where = (f"between {ms[0].between[0]} and {ms[0].between[1]} (on every measured mode"
                 + ("; its participation in modes 2..N fitted" if ms[0].setup.joint_shape else "") + ")"
                 if getattr(ms[0], "between", None) else "on mode 1 of the measured modes")
        d["error"] = ("simulation error of the measured responses (each channel in its quantity, "
                      f"over its rms), the joint {where}")
        d["drive_path"] = drive_path(d, ms[0])
        d["parameters_per"] = ("unit modal mass: the joint's parameters act on q, mode 1's "
                               "displacement at the reference sensor (m); N reads N/kg")
    return d


def drive_path(d: dict[str, Any], m: Any) -> str:
    """Which model of the amplifier and shaker the modal fit used, in words."""
    pars = d.get("parameters") or {}
    val = lambda n: (pars.get(n) or {}).get("value") if isinstance(pars.get(n), dict) else None  # noqa: E731
    hp = val("shaker.highpass_hz")
    path = m.setup.shaker
    if path is None:
        hp_text = ("a fitted high-pass" if hp is None else
                   f"a high-pass at {hp:.3g} Hz (fitted)" if hp > 0 else "no high-pass (fitted to 0)")
        lag = val("shaker.lag_s")
        if lag is not None:
            hp_text += f" -> a lag of {lag * 1e3:.3g} ms (fitted)" if lag > 0 else " -> no lag (fitted to 0)"
        return (f"{m.metadata.get('drive_quantity', 'drive')} -> {hp_text} -> a fitted gain "
                "(modal.drive) on every mode: per "
                f"{'volt' if m.metadata.get('drive_quantity') == 'voltage' else 'newton'} only")
    vals = {n: val(n) for n in pars if val(n) is not None}
    try:
        coil = path.coil_used(m.drive, vals, m.basis.modes[0].frequency_hz) if path.free is None \
            or path.free in vals else None
    except InputError:
        coil = None
    if m.between:          # the two-point model leaves the coil's lag out (nlmode_shaker)
        return path.describe(vals, hp or 0.0, False, every=True)
    return path.describe(vals, hp or 0.0, coil)


def settings_from(options: dict[str, Any]) -> DiagnoseSettings:
    """DiagnoseSettings from keyword options; unknown or bad values raise InputError."""
    sig = {}
    for k in SIG_KEYS:
        if k in options and options[k] is not None:
            sig[k] = _positive(options[k], k)
    cands = options.get("candidates")
    if isinstance(cands, str):
        cands = [c.strip() for c in cands.split(",") if c.strip()]
    factor = _positive(options.get("factor", 1.5), "factor")
    n_jobs = options.get("n_jobs")
    if n_jobs is not None and (isinstance(n_jobs, bool) or not isinstance(n_jobs, int) or n_jobs < 1):
        raise InputError(f"must be a whole number >= 1, got {n_jobs!r}", field="n_jobs")
    return DiagnoseSettings(factor=factor, significance=SignificanceSettings(**sig),
                            n_jobs=n_jobs, multistart=options.get("multistart", "auto"),
                            seed=int(options.get("seed", 0)), warm=bool(options.get("warm", True)),
                            candidates=tuple(cands) if cands else None,
                            executor=options.get("executor"))


def _positive(v: Any, name: str) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"must be a number, got {v!r}", field=name) from None
    if not x > 0:
        raise InputError(f"must be > 0, got {v!r}", field=name)
    return x


def _check(options: dict[str, Any], allowed: Iterable[str]) -> None:
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise InputError(f"unknown option(s) {unknown}; known: {sorted(allowed)}", field=unknown[0])


COMMON = ("validate", "prime_cycles", "multistart", "seed", "full", "progress", "kind",
          "warmup", "plausibility") + FRF_OPTIONS + MODAL_OPTIONS
DIAG = COMMON + SIG_KEYS + ("factor", "n_jobs", "candidates", "warm", "executor")


@dataclass
class FitReport:
    """A model fitted to runs, evaluated on them, with the noise floor and curves."""

    fit: FitResult
    evaluation: Evaluation
    noise: NoiseFloor
    curves: Any
    maps: Any
    validation_runs: list[str]

    def to_dict(self, full: bool = False) -> dict[str, Any]:
        d: dict[str, Any] = {
            "model": self.fit.model.expr, "kind": kind_of(self.evaluation.runs_measured()).name,
            "parameters": parameters_dict(self.fit),
            "flags": self.fit.flags_,
            "asymmetry": fit_asymmetry(self.fit, [r.run for r in self.evaluation.runs]),
            "nrmse": self.evaluation.nrmse(), "noise_floor": self.noise.nrmse,
            "runs": [r.to_dict() for r in self.evaluation.runs],
            "fit_runs": list(self.fit.fit_runs_), "validation_runs": self.validation_runs,
            "nrmse_validation": (self.evaluation.nrmse(self.validation_runs)
                                 if self.validation_runs else None),
            "success": self.fit.success_, "message": self.fit.message_,
        }
        if full:
            d.update(curves=self.curves.to_dict(), maps=self.maps.to_dict(),
                     loops=kind_of(self.evaluation.runs_measured()).loops(self.evaluation.runs), noise=self.noise.to_dict(),
                     correlation={"parameters": list(self.fit.varied_),
                                  "matrix": self.fit.correlation_})
        return d


def fit_report(runs: Any, model: str | Model, **options: Any) -> FitReport:
    """Fit ``model`` to the runs (all of them, or all but ``validate``)."""
    _check(options, COMMON)
    prepared, val = _load(runs, options)
    val = val or []
    fit_r = [r for r in prepared if r.name not in set(val)]
    val_r = [r for r in prepared if r.name in set(val)]
    m = Model.parse(model)
    kind = kind_of(prepared)
    nf = noise_floor(prepared)
    own = getattr(kind, "fit", None)
    fit = own(m, fit_r, val_r) if own is not None else ModelFitter(
        m, multistart=options.get("multistart", "auto"), seed=int(options.get("seed", 0))).fit(
        [r.data for r in fit_r], validation=[r.data for r in val_r] or None,
        floor=nf.over(fit_r))
    ev = evaluate(m, fit.params_, prepared)
    return FitReport(fit, ev, nf, kind.curves(ev.runs), kind.maps(ev.runs, nf.by_run()), val)


def fit_runs(runs: Any, model: str | Model, **options: Any) -> dict[str, Any]:
    """`labjoint fit` JSON: model, parameters {value, stderr, unit}, nrmse, noise_floor, runs."""
    full = bool(options.get("full", False))
    report = fit_report(runs, model, **options)
    return clean(_measured(report.to_dict(full=full), report.evaluation.runs_measured()))


def diagnose_report(runs: Any, model: str | Model, **options: Any) -> Diagnosis:
    """Where ``model`` fails and which effect is missing (:mod:`.diagnosis`)."""
    _check(options, DIAG)
    prepared, val = _load(runs, options)
    return diagnose_prepared(prepared, model, validate=val, settings=settings_from(options),
                             progress=options.get("progress"))


def diagnose_runs(runs: Any, model: str | Model, **options: Any) -> dict[str, Any]:
    """`labjoint diagnose` JSON: model, nrmse, noise_floor, adequate, failures, candidates."""
    full = bool(options.get("full", False))
    report = diagnose_report(runs, model, **options)
    d = report.to_dict(full=full)
    if full and "loops" not in d:
        d["loops"] = kind_of(report.evaluation.runs_measured()).loops(report.evaluation.runs)
    return clean(_measured(d, report.evaluation.runs_measured()))


def ladder_report(runs: Any, model: str | Model, max_steps: int | None = None,
                  auto: bool = True, **options: Any) -> tuple[Ladder, list[str], dict[str, str]]:
    """The ladder, the run files it was saved to (``save``, default True) and the files
    that could not take it (path -> reason)."""
    save = bool(options.pop("save", True))
    _check(options, DIAG)
    prepared, val = _load(runs, options)
    lad = build_ladder(prepared, model, max_steps=max_steps, auto=bool(auto), validate=val,
                       settings=settings_from(options), progress=options.get("progress"))
    errors: dict[str, str] = {}
    if save and {m.kind for m in prepared} <= {"frf", "backbone"}:
        return lad, save_beside(lad.to_dict(), prepared, lad.start, "ladder"), errors
    saved = save_ladder(lad.to_dict(), [r.path for r in prepared], errors) if save else []
    return lad, saved, errors


def ladder_runs(runs: Any, model: str | Model, max_steps: int | None = None, auto: bool = True,
                **options: Any) -> dict[str, Any]:
    """`labjoint ladder` JSON: steps [{model, added, nrmse}], noise_floor, adequate."""
    full = bool(options.get("full", False))
    lad, saved, errors = ladder_report(runs, model, max_steps, auto, **options)
    d = lad.to_dict(full=full)
    fd, dg = d.get("final_diagnosis"), lad.steps[-1].diagnosis
    if full and isinstance(fd, dict) and dg is not None and "loops" not in fd:
        fd["loops"] = kind_of(dg.evaluation.runs_measured()).loops(dg.evaluation.runs)
    d["saved"] = saved
    _measured(d, lad.steps[-1].diagnosis.evaluation.runs_measured() if lad.steps[-1].diagnosis
              else [])
    if errors:
        d["not_saved"] = errors
    return clean(d)
