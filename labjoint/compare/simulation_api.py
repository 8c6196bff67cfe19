"""Simulation-error fit, diagnose and ladder from keyword options (what REST jobs send),
with the series a page draws: measured and predicted displacement over a window of each
record, and the residual's RMS along the whole record."""

from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np

from labjoint.compare.output_error import Prediction, fit_simulation
from labjoint.compare.significance import SignificanceSettings
from labjoint.compare.simulation_loop import diagnose_simulation, ladder_simulation
from labjoint.errors import InputError

#: Samples of each record drawn at full rate (the last ones judged), and the number of
#: segments the residual's RMS is given over along the whole record.
WINDOW_SAMPLES = 3000
SEGMENTS = 100
#: Options of the simulation kind (the rest of a model job's options are refused with it).
OPTIONS = ("validate", "periodic", "warmup", "seed", "factor", "alpha", "candidates", "full",
           "error", "kind", "start", "bounds")


def prediction_series(p: Prediction, window: int = WINDOW_SAMPLES,
                      segments: int = SEGMENTS) -> dict[str, Any]:
    """One prediction as plot data: a full-rate window and the residual RMS per segment.

    >>> y = np.sin(np.arange(5000) / 50.0)
    >>> s = prediction_series(Prediction("r", y * 0.9, y, np.ones(5000, bool), 0.01, 1000.0))
    >>> len(s["time_s"]), len(s["segment_rms_m"]), round(max(s["segment_rms_m"]), 2)
    (3000, 100, 0.1)
    """
    judged = np.flatnonzero(p.judged)
    stop = int(judged[-1]) + 1 if judged.size else p.measured.size
    start = max(0, stop - window)
    t = np.arange(p.measured.size) / p.fs
    r = np.where(p.judged, p.measured - p.predicted, np.nan)
    edges = np.linspace(0, r.size, min(segments, r.size) + 1).astype(int)
    seg_rms, seg_t = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        part = r[a:b][np.isfinite(r[a:b])]
        seg_rms.append(float(np.sqrt(np.mean(part ** 2))) if part.size else None)
        seg_t.append(float(t[(a + b - 1) // 2]))
    return {"run": p.name, "rmse": p.rmse, "nrmse": p.nrmse, "noise_std_m": p.noise_std_m,
            "time_s": t[start:stop].tolist(), "measured_m": p.measured[start:stop].tolist(),
            "predicted_m": p.predicted[start:stop].tolist(),
            "segment_time_s": seg_t, "segment_rms_m": seg_rms}


def check_options(options: dict[str, Any]) -> None:
    """Refuse options that simulation error does not take (InputError names the option)."""
    bad = sorted(set(options) - set(OPTIONS))
    if bad:
        raise InputError(f"does not go with error = 'simulation'; its options are "
                         f"{sorted(OPTIONS)}", field=f"options.{bad[0]}")
    if options.get("kind", "auto") == "sine":
        raise InputError("simulation error judges records (kind 'record' or 'auto')",
                         field="options.kind")


def simulation_job(operation: str, runs: Sequence[Any], model: str, options: dict[str, Any], *,
                   max_steps: int | None = None,
                   progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run ``operation`` (fit, diagnose or ladder) by simulation error."""
    check_options(options)
    common = {"validate": options.get("validate"), "periodic": bool(options.get("periodic", False)),
              "warmup": options.get("warmup", "auto"), "seed": int(options.get("seed", 0))}
    user = {"start": options.get("start") or None,
            "bounds": {k: tuple(v) for k, v in (options.get("bounds") or {}).items()} or None}
    if operation == "fit":
        fit = fit_simulation(list(runs), model, **common, **user)
        out = fit.to_dict()
        if options.get("full"):
            out["series"] = [prediction_series(p) for p in fit.fit]
            out["validation_series"] = [prediction_series(p) for p in fit.validation]
        return out
    loop = {**common, "factor": float(options.get("factor", 1.5)),
            "significance": SignificanceSettings(**({"alpha": options["alpha"]}
                                                    if options.get("alpha") else {})),
            "candidates": options.get("candidates"), **user}
    if operation == "diagnose":
        return diagnose_simulation(list(runs), model, progress=progress, **loop).to_dict()
    if operation == "ladder":
        return ladder_simulation(list(runs), model, max_steps=max_steps, progress=progress, **loop)
    raise InputError(f"unknown operation {operation!r}; known: fit, diagnose, ladder",
                     field="operation")
