"""The modal kind's bounded simulation-error fit, shared by the joint on a mode
(:mod:`.modal_fit`) and the joint between two points (:mod:`.modal_pair_fit`): the best
of a list of starts by its residual, then ``scipy.optimize.least_squares`` inside the
bounds in units of that start (a parameter started at 0, e.g. the shaker path's high-pass
corner or an offset, in units of a tenth of its bounded range, else 1: in units of its own
zero it could never move, the solver's finite-difference step being 1e-4 of the unit).
A trial whose simulation diverges costs ``PENALTY`` times
the start's residual norm (spread over the residual's length), so the solver backs off
instead of stopping."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np
from scipy.optimize import OptimizeResult, least_squares

from labjoint.errors import InputError
from labjoint.models import FitResult
from labjoint.models.scores import nrmse_from_sums, pooled_nrmse

PENALTY = 1e3


def best_start_then_solve(residual: Callable[[np.ndarray], np.ndarray | None], names: Sequence[str],
                          bounds: Mapping[str, tuple[float, float]], starts: Iterable[np.ndarray],
                          max_nfev: int | None, diverged: str
                          ) -> tuple[np.ndarray, OptimizeResult, np.ndarray]:
    """(x, the solver's result, the scale of its unknowns: x = sol.x * scale).
    ``residual(x)`` is None where the model diverges; when every start does, InputError
    with the message ``diverged``."""
    best, best_cost = None, np.inf
    for x in starts:
        r = residual(x)
        if r is not None and float(r @ r) < best_cost:
            best, best_cost = x, float(r @ r)
    if best is None:
        raise InputError(diverged, field="model")
    size = best_cost ** 0.5
    last = [np.zeros(0)]

    def fun(x: np.ndarray) -> np.ndarray:
        r = residual(x)
        if r is None:
            n = max(1, last[0].size)
            return np.full(n, PENALTY * size / n ** 0.5)
        last[0] = r
        return r

    fun(best)
    lo = np.array([bounds[n][0] for n in names])
    hi = np.array([bounds[n][1] for n in names])
    span = hi - lo
    unit = np.where(np.isfinite(span) & (span > 0), 0.1 * np.where(np.isfinite(span), span, 0.0), 1.0)
    scale = np.where(np.abs(best) > 1e-12 * unit, np.abs(best), unit)
    sol = least_squares(lambda z: fun(z * scale), best / scale, bounds=(lo / scale, hi / scale),
                        max_nfev=max_nfev or 40 * len(names), x_scale=1.0, diff_step=1e-4)
    return sol.x * scale, sol, scale


def modal_result(model: Any, params: Any, names: Sequence[str], stderr: Mapping[str, float],
                 corr: np.ndarray, sol: OptimizeResult, r: np.ndarray, fit_ms: Sequence[Any],
                 val_ms: Sequence[Any]) -> FitResult:
    """The FitResult of a modal fit: each record's NRMSE under the fitted ``params`` (a
    diverging prediction counts as inf), pooled over the fit and the validation records."""
    sse, ssf = {}, {}
    for m in (*fit_ms, *val_ms):
        e = m.predict(model, params) - m.data.force
        sse[m.name] = float(e @ e) if np.all(np.isfinite(e)) else float("inf")
        ssf[m.name] = float(m.data.force @ m.data.force)
    fn, vn = [m.name for m in fit_ms], [m.name for m in val_ms]
    return FitResult(model, params, tuple(names), dict(stderr), corr,
                     pooled_nrmse([sse[n] for n in fn], [ssf[n] for n in fn]),
                     {n: nrmse_from_sums(sse[n], ssf[n]) for n in fn},
                     pooled_nrmse([sse[n] for n in vn], [ssf[n] for n in vn]) if vn else None,
                     {n: nrmse_from_sums(sse[n], ssf[n]) for n in vn}, int(sol.nfev), bool(sol.success),
                     str(sol.message), int(r.size), float(r @ r), (), tuple(fn), tuple(vn))
