"""NRMSE (design.md), defined once: rms(F_measured - F_model) / rms(F_measured) over the
steady samples, from sums of squares so runs pool by their samples; :func:`nrmse` of a
model with parameters on runs."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

from labjoint.errors import InputError
from labjoint.models.composition import Model
from labjoint.models.inputs import RunData
from labjoint.models.params import Parameters


def nrmse_from_sums(sse: float, ssf: float) -> float:
    """sqrt(sum of squared residuals / sum of squared measured force); inf when the
    measured force is identically zero (nothing to normalise by).

    >>> nrmse_from_sums(1.0, 100.0)
    0.1
    >>> nrmse_from_sums(1.0, 0.0)
    inf
    """
    return math.sqrt(sse / ssf) if ssf > 0 else math.inf


def pooled_nrmse(sse: Iterable[float], ssf: Iterable[float]) -> float:
    """NRMSE pooled over runs (each counts by its samples); NaN for no runs.

    >>> pooled_nrmse([1.0, 3.0], [100.0, 300.0])
    0.1
    >>> pooled_nrmse([], [])
    nan
    """
    e, f = list(sse), list(ssf)
    return nrmse_from_sums(sum(e), sum(f)) if e else math.nan


def run_labels(runs: Sequence[RunData]) -> list[str]:
    """Unique run labels: names, with #k appended to repeats (or run<i> if unnamed)."""
    out, seen = [], {}
    for i, r in enumerate(runs):
        base = r.name or f"run{i}"
        seen[base] = seen.get(base, 0) + 1
        out.append(base if seen[base] == 1 else f"{base}#{seen[base]}")
    return out


def as_runs(runs: RunData | Sequence[RunData], field: str) -> list[RunData]:
    runs = [runs] if isinstance(runs, RunData) else list(runs)
    for r in runs:
        if not isinstance(r, RunData):
            raise InputError(f"expected RunData items, got {type(r).__name__}", field=field)
    return runs


def nrmse(model: Model | str, params: Parameters | dict[str, Any],
          runs: RunData | Sequence[RunData]) -> tuple[float, dict[str, float]]:
    """Pooled NRMSE (design.md) over the steady samples of ``runs``, and per run."""
    model = Model.parse(model)
    runs = as_runs(runs, "runs")
    num = den = 0.0
    per = {}
    for lab, r in zip(run_labels(runs), runs):
        m = r.steady
        e = r.force[m] - model.eval(params, r)[m]
        se, sf = float(e @ e), float(r.force[m] @ r.force[m])
        per[lab] = nrmse_from_sums(se, sf)
        num += se
        den += sf
    return nrmse_from_sums(num, den), per
