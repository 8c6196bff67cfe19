"""The outcome of a fit, kept apart from the model and the fitter."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.models.composition import Model
from labjoint.models.params import Parameters


def _num(x: float | None) -> float | None:
    """JSON-safe float: non-finite -> None."""
    return None if x is None or not math.isfinite(x) else float(x)


def parameter_flags(values: dict[str, float], stderr: dict[str, float | None]
                    ) -> dict[str, str]:
    """name -> why a fitted value should not be read as a result: its standard error is
    undetermined (NaN: the covariance is singular along it, the data do not fix it) or
    exceeds the value itself (the data do not tell it from zero).

    >>> parameter_flags({"a.k": 1.26e6, "a.m": 7e-4, "a.c": 3.0},
    ...                 {"a.k": 8.8e6, "a.m": float("nan"), "a.c": 0.1})
    {'a.k': 'standard error 8.8e+06 exceeds the value 1.26e+06: the data do not tell it from zero', 'a.m': 'undetermined: the data do not fix it (singular covariance), no standard error'}
    """
    out = {}
    for k, se in stderr.items():
        v = values.get(k, math.nan)
        if se is None or not math.isfinite(se):
            out[k] = "undetermined: the data do not fix it (singular covariance), no standard error"
        elif se > abs(v):
            out[k] = (f"standard error {se:.3g} exceeds the value {v:.3g}: the data do not tell "
                      "it from zero")
    return out


def parameter_table(params: Parameters, stderr: dict[str, float | None],
                    flags: dict[str, str]) -> dict[str, dict[str, Any]]:
    """``{name: {"value", "stderr", "unit"}}`` with ``"flag"`` where :func:`parameter_flags`
    gives one; an undetermined (None or non-finite) standard error is null, never a number."""
    out: dict[str, dict[str, Any]] = {}
    for k, p in params.items():
        se = stderr.get(k)
        out[k] = {"value": p.value, "stderr": None if se is None or not np.isfinite(se) else se,
                  "unit": p.unit}
        if k in flags:
            out[k]["flag"] = flags[k]
    return out


@dataclass
class FitResult:
    """Parameters learned from a set of runs, their uncertainty and the fit quality.

    ``params_`` holds the fitted values (``stderr`` filled for varied parameters);
    ``stderr_`` maps varied parameter -> standard error from (J^T J)^-1 s^2 (NaN when the
    data do not determine it: a singular covariance; :func:`parameter_flags` says so); ``correlation_`` is the correlation matrix of the varied
    parameters, ordered as ``varied_``. NRMSE (design.md): rms(F_meas - F_model) /
    rms(F_meas) pooled over the steady samples of the fit runs (``nrmse_``), per run
    (``run_nrmse_``), and over the validation runs if any (``validation_nrmse_``,
    ``validation_run_nrmse_``).
    """

    model: Model
    params_: Parameters
    varied_: tuple[str, ...]
    stderr_: dict[str, float]
    correlation_: np.ndarray
    nrmse_: float
    run_nrmse_: dict[str, float]
    validation_nrmse_: float | None = None
    validation_run_nrmse_: dict[str, float] = field(default_factory=dict)
    n_evals_: int = 0
    success_: bool = False
    message_: str = ""
    n_samples_: int = 0
    ssr_: float = math.nan
    start_costs_: tuple[float, ...] = ()
    fit_runs_: tuple[str, ...] = ()
    validation_runs_: tuple[str, ...] = ()

    @property
    def values_(self) -> dict[str, float]:
        return self.params_.valuesdict()

    @property
    def flags_(self) -> dict[str, str]:
        """Parameters whose standard error is undetermined or exceeds the value."""
        return parameter_flags(self.values_, self.stderr_)

    def correlation(self, a: str, b: str) -> float:
        """Correlation coefficient of two varied parameters."""
        i, j = self.varied_.index(a), self.varied_.index(b)
        return float(self.correlation_[i, j])

    def __repr__(self) -> str:
        return (f"FitResult('{self.model.expr}', nrmse={self.nrmse_:.4g}, "
                f"validation_nrmse={self.validation_nrmse_}, success={self.success_})")

    def report(self) -> str:
        """Plain-text table: parameter, value, stderr, unit."""
        lines = [f"model {self.model.expr}: NRMSE {self.nrmse_:.4g} over {len(self.fit_runs_)} run(s)"
                 + ("" if self.validation_nrmse_ is None
                    else f", validation NRMSE {self.validation_nrmse_:.4g}")]
        for k, p in self.params_.items():
            se = "fixed" if k not in self.stderr_ else f"+- {self.stderr_[k]:.3g}"
            flag = self.flags_.get(k)
            lines.append(f"  {k:28s} {p.value:12.5g} {se:>14s} {p.unit}"
                         + (f"  ({flag})" if flag else ""))
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe summary (model as registry names + parameters)."""
        corr = [[_num(x) for x in row] for row in np.asarray(self.correlation_)]
        return {
            **self.model.to_dict(self.params_),
            "varied": list(self.varied_),
            "stderr": {k: _num(v) for k, v in self.stderr_.items()},
            "flags": self.flags_,
            "correlation": corr,
            "nrmse": _num(self.nrmse_),
            "run_nrmse": {k: _num(v) for k, v in self.run_nrmse_.items()},
            "validation_nrmse": _num(self.validation_nrmse_),
            "validation_run_nrmse": {k: _num(v) for k, v in self.validation_run_nrmse_.items()},
            "n_evals": self.n_evals_, "success": self.success_, "message": self.message_,
            "n_samples": self.n_samples_, "ssr": _num(self.ssr_),
            "start_costs": [_num(c) for c in self.start_costs_],
            "fit_runs": list(self.fit_runs_), "validation_runs": list(self.validation_runs_),
        }
