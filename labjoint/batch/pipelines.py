"""The pipelines a reprocess runs, and their versions.

A pipeline takes run files (one, or a group for the model pipelines), writes its result
into each file's ``/entry/processed/<name>`` and returns a small JSON summary.

Version rule: a pipeline's version is ``<name>-`` followed by the first 16 hex digits of
a sha256 over, in order, (1) for every package the pipeline's code lives in
(:attr:`Pipeline.packages`), every ``*.py`` file under it sorted by its path relative to
``labjoint/``, as the path, a NUL, the file's bytes, a NUL; (2) this module's own source
(it maps options to calls); (3) the canonical JSON of :attr:`Pipeline.settings` (settings
that live outside those files; the pipelines' defaults, such as the filter's cutoff and
order, are constants in the hashed packages). Editing any of these files, even a comment,
gives a new version; code outside these packages (storage, config, the CLI) does not.
Computing it reads the files without importing them (a no-op reprocess stays fast).
The options a result was computed with are not in the version: they are part of the
result's key (:func:`labjoint.storage.results.options_hash`).
"""

from __future__ import annotations

import hashlib
import json
import multiprocessing
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable

import numpy as np

import labjoint
from labjoint.errors import InputError

ROOT = Path(labjoint.__file__).resolve().parent
#: analyze's summary: the design.md analyze fields and the resolution flag
LOOP_KEYS = ("frequency_hz", "displacement_amplitude_m", "force_amplitude_n", "energy_loss_j",
             "damping_ns_per_m", "stiffness_n_per_m", "cycles", "below_resolution")
#: options of the comparison pipelines passed to labjoint.compare as they are
COMPARE_KEYS = ("validate", "prime_cycles", "seed", "kind", "warmup")
JUDGE_KEYS = ("factor", "alpha", "candidates")


@dataclass(frozen=True)
class Pipeline:
    """A pipeline: its code packages, settings, and the function that runs it."""

    name: str
    packages: tuple[str, ...]
    run: Callable[[list[Path], dict[str, Any], Any], dict[str, Any]]
    grouped: bool = False
    settings: dict[str, Any] = field(default_factory=dict)


def _analyze(paths: list[Path], options: dict[str, Any], executor: Any = None) -> dict[str, Any]:
    """Hysteresis loop of one run (seed 002 Eq. 1) into ``processed/loop``."""
    from labjoint.identify.analyze import analyze_file
    from labjoint.identify.methods import loop_processed
    from labjoint.storage.processed import write_processed

    (path,) = paths
    res = analyze_file(path, force=options.get("force", "joint"),
                       threads=bool(options.get("threads", True)))
    write_processed(path, "loop", *loop_processed(res))
    return {k: _plain(res.summary.get(k)) for k in LOOP_KEYS}


def _stickslip(paths: list[Path], options: dict[str, Any], executor: Any = None
               ) -> dict[str, Any]:
    """Stick-slip boundary (seed 002 Eqs. 2-9) into ``processed/stickslip``."""
    from labjoint.identify.methods import analyze_runs

    if options.get("friction") is None:
        raise InputError("the stick-slip pipeline needs the friction coefficient "
                         "(--friction MU, or identify it: labjoint friction RUN)",
                         field="friction")
    (row,) = analyze_runs(paths, "stickslip", friction=float(options["friction"]), store=True,
                          force=options.get("force", "joint"))
    return {k: _plain(v) for k, v in row.items()
            if k.startswith("stickslip_") and k != "stickslip_basis"}


def _compare_options(options: dict[str, Any], judging: bool, executor: Any = None
                     ) -> dict[str, Any]:
    """compare's options; candidate refits on ``executor`` when given, else in this
    process when it may not start processes (a Dask worker is a daemonic process),
    else in compare's default local processes."""
    keys = COMPARE_KEYS + (JUDGE_KEYS if judging else ())
    out = {k: options[k] for k in keys if options.get(k) is not None}
    if options.get("plausibility"):       # the checked table (batch.options) as the limits
        from labjoint.identify.plausible import Plausibility

        out["plausibility"] = Plausibility.from_mapping(options["plausibility"])
    if judging:
        if executor is not None:
            out["executor"] = executor
        elif multiprocessing.current_process().daemon:
            out["n_jobs"] = 1
    return out


def _model_group(options: dict[str, Any]) -> str:
    return f"{options['pipeline']}_{options['options_hash'][:8]}"


def _save_model_result(paths: list[Path], options: dict[str, Any], res: dict[str, Any],
                       summary: dict[str, Any]) -> None:
    """The result's JSON and its NRMSE into every run of the group."""
    from labjoint.storage.processed import write_processed

    arrays = {"nrmse": float(_nan(res.get("nrmse"))),
              "noise_floor": float(_nan(res.get("noise_floor")))}
    attrs = {"model": str(res.get("model", options.get("model"))),
             "result": json.dumps(summary, allow_nan=False, default=str),
             "runs": json.dumps([p.stem for p in paths])}
    for p in paths:
        write_processed(p, _model_group(options), arrays, attrs, units={})


def _need_model(options: dict[str, Any]) -> str:
    model = options.get("model")
    if not model:
        raise InputError("the model pipelines need --model EXPR", field="model")
    return str(model)


def _fit(paths: list[Path], options: dict[str, Any], executor: Any = None) -> dict[str, Any]:
    from labjoint.compare import fit_runs

    res = fit_runs([str(p) for p in paths], _need_model(options), **_compare_options(options, False))
    summary = {"model": res["model"], "nrmse": res["nrmse"], "noise_floor": res["noise_floor"],
               "parameters": {k: v["value"] for k, v in res["parameters"].items()}}
    _save_model_result(paths, options, res, summary)
    return summary


def _diagnose(paths: list[Path], options: dict[str, Any], executor: Any = None
              ) -> dict[str, Any]:
    from labjoint.compare import diagnose_runs

    res = diagnose_runs([str(p) for p in paths], _need_model(options),
                        **_compare_options(options, True, executor))
    summary = {"model": res["model"], "nrmse": res["nrmse"], "noise_floor": res["noise_floor"],
               "adequate": res["adequate"], "verdict": res["verdict"],
               "candidates": [c["effect"] for c in res["candidates"]],
               "significant": [c["effect"] for c in res["candidates"] if c["significant"]]}
    _save_model_result(paths, options, res, summary)
    return summary


def _ladder(paths: list[Path], options: dict[str, Any], executor: Any = None) -> dict[str, Any]:
    from labjoint.compare import ladder_runs

    res = ladder_runs([str(p) for p in paths], _need_model(options),
                      max_steps=options.get("max_steps"), save=True,
                      **_compare_options(options, True, executor))
    return {"final_model": res["final_model"], "adequate": res["adequate"],
            "noise_floor": res["noise_floor"], "key": res["key"],
            "steps": [s["model"] for s in res["steps"]]}


_SIGNAL = ("signal", "identify")
_MODELS = ("signal", "identify", "models", "structure", "compare")
PIPELINES: dict[str, Pipeline] = {
    "analyze": Pipeline("analyze", _SIGNAL, _analyze),
    "stickslip": Pipeline("stickslip", _SIGNAL, _stickslip),
    "fit": Pipeline("fit", _MODELS, _fit, grouped=True),
    "diagnose": Pipeline("diagnose", _MODELS, _diagnose, grouped=True),
    "ladder": Pipeline("ladder", _MODELS, _ladder, grouped=True),
}


def get_pipeline(name: str) -> Pipeline:
    """The pipeline called ``name``; an unknown name lists the known ones."""
    try:
        return PIPELINES[name]
    except KeyError:
        raise InputError(f"unknown pipeline {name!r}; known: {sorted(PIPELINES)}",
                         field="pipeline") from None


@lru_cache(maxsize=None)
def pipeline_version(name: str) -> str:
    """The version of pipeline ``name`` by the module docstring's rule (cached per process)."""
    pipe = get_pipeline(name)
    h = hashlib.sha256()
    for pkg in pipe.packages:
        for p in sorted((ROOT / pkg).rglob("*.py")):
            h.update(str(p.relative_to(ROOT)).encode() + b"\0" + p.read_bytes() + b"\0")
    h.update(Path(__file__).read_bytes() + b"\0")
    h.update(json.dumps(pipe.settings, sort_keys=True).encode())
    return f"{name}-{h.hexdigest()[:16]}"


def _nan(v: Any) -> float:
    return float("nan") if v is None else float(v)


def _plain(v: Any) -> Any:
    """A summary value as plain JSON (numpy scalars as numbers, NaN as None)."""
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v
