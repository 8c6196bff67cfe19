"""NRMSE (design.md), defined once: rms(F_measured - F_model) / rms(F_measured) over the
steady samples, from sums of squares so runs pool by their samples."""

from __future__ import annotations

import math
from collections.abc import Iterable


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
