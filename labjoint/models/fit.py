"""Fit one parameter set of a joint model to many runs at once (amplitudes, frequencies,
torques), and validate it on other runs (seed 000: fit on one mode, validate on another).

Method. Residuals are F_measured - F_model on the steady samples of every fit run,
concatenated, so each run counts by its number of samples and the cost is the pooled
NRMSE of design.md. Parameters of force effects (linear_stiffness k, viscous c,
cubic_stiffness k3, offset F0, inertia m) enter linearly and are solved exactly by
(bounded) linear least squares inside the nonlinear loop (variable projection); the
others are fitted by ``scipy.optimize.least_squares`` (trf, bounds, 2-point Jacobian) in
scaled coordinates: x = ln(p / p0) for the effects' strictly positive scale parameters
(stiffnesses, forces, lambda, E_w), x = (p - p0) / s otherwise, s the effect's typical
magnitude, so every x is of order one (a trust box of x1e6 around the start keeps log
parameters finite). Starting values come from the data's loop quantities (slope, area,
force amplitude; :mod:`labjoint.models.summary`) or from a previous fit (warm start).
Multi-start: the first start is polished; with multistart="auto" further starts are
tried only while the pooled NRMSE stays above 1.2 x the noise floor (the caller's, e.g.
the comparison's estimate for its kind of measurement; else the period-to-period scatter
of the measured force, :func:`labjoint.models.summary.period_shift_floor`), each from
the best of 4 random draws around the first start (log-normal x3 for scale
parameters, uniform within finite bounds, +-1 typical magnitude otherwise); the lowest
cost wins. With a warm start only the new parameters are drawn.
Uncertainty: the Jacobian J of the residuals in natural units for all varied parameters
at the optimum (central differences for the nonlinear ones, the regressors for the
linear ones), covariance (J^T J)^-1 s^2 with s^2 = SSR / (N - P), standard errors and
correlations. They assume independent residuals; noise correlated in time or model
error make them optimistic.
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import nullcontext
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares, lsq_linear

from labjoint.errors import InputError
from labjoint.models.composition import Model
from labjoint.models.covariance import covariance
from labjoint.models.effects.base import ForceEffect
from labjoint.models.inputs import RunData
from labjoint.models.params import Parameters
from labjoint.models.result import FitResult
from labjoint.models.scores import as_runs, run_labels, nrmse
from labjoint.models.summary import LoopSummary, period_shift_floor



def one_blas_thread() -> Any:
    """A context in which BLAS/LAPACK use one thread (threadpoolctl; a no-op without it).

    trf factors the tall, thin Jacobian (samples x parameters) by SVD at every iteration;
    a threaded BLAS splits that into pieces too small to share, and its threads spin
    waiting for each other whenever the cores are busy (two diagnosis workers on two
    cores, or any other load): for 57,600 x 7 at load 11 on 2 cores, 164-176 ms per SVD
    on two threads against 27-28 ms on one (medians; the best of 30: 57 against 17 ms).
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:                                        # pragma: no cover
        return nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


TRUST = 1e6
FD_REL = 1e-5
STOP_FACTOR = 1.2   # multistart "auto" stops once NRMSE <= this x the noise floor
NUDGE = 0.05        # scaled distance a start keeps from a bound
SCREEN = 4          # random draws screened (one evaluation each) per extra start
#: least_squares stops when an iteration lowers the cost by less than FTOL (relative) or
#: moves the scaled coordinates by less than XTOL: far below what the NRMSE or the
#: parameters' standard errors resolve, and it spares the creeping steps of flat valleys
FTOL = 1e-6
XTOL = 1e-6


@dataclass
class _Coord:
    """Scaled coordinate of one nonlinear parameter."""

    name: str
    ref: float
    scale: float
    log: bool
    lower: float
    upper: float

    def to_p(self, x: float) -> float:
        p = self.ref * np.exp(x) if self.log else self.ref + x * self.scale
        return float(min(max(p, self.lower), self.upper))

    def bounds(self) -> tuple[float, float]:
        if self.log:
            lo = np.log(max(self.lower, self.ref / TRUST) / self.ref)
            hi = np.log(min(self.upper, self.ref * TRUST) / self.ref)
            return float(lo), float(hi)
        return (self.lower - self.ref) / self.scale, (self.upper - self.ref) / self.scale

    def to_x(self, p: float) -> float:
        if self.log:
            return float(np.log(max(p, 1e-300) / self.ref))
        return (p - self.ref) / self.scale


class _Problem:
    """Residuals of a model over the steady samples of runs, with variable projection."""

    def __init__(self, model: Model, runs: list[RunData], params: Parameters,
                 summary: LoopSummary, solve_linear: bool) -> None:
        self.model, self.runs, self.params = model, runs, params
        self.y = np.concatenate([r.force[r.steady] for r in runs])
        self.linear: list[str] = []      # varied parameters solved by linear least squares
        self.coords: list[_Coord] = []   # varied parameters fitted nonlinearly
        for e in model.effects:
            guess = {p.name: params[f"{e.name}.{p.name}"].value for p in e.params}
            scales = e.scales(summary, guess)
            for p in e.params:
                key = f"{e.name}.{p.name}"
                par = params[key]
                if not par.vary or par.lower == par.upper:
                    continue
                if solve_linear and isinstance(e, ForceEffect):
                    self.linear.append(key)
                    continue
                log = p.name in e.log_params and par.value > 0 and par.lower >= 0
                self.coords.append(_Coord(key, par.value, max(abs(scales[p.name]), 1e-300),
                                          log, par.lower, par.upper))
        self.lin_effects = [k.split(".")[0] for k in self.linear]
        self.n_evals = 0

    def values(self, x: np.ndarray) -> dict[str, float]:
        v = self.params.valuesdict()
        for c, xi in zip(self.coords, x):
            v[c.name] = c.to_p(xi)
        for k in self.linear:  # placeholder inside bounds; replaced by the projection
            p = self.params[k]
            v[k] = float(np.clip(0.0, p.lower, p.upper))
        return v

    def _split(self, v: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        rest, cols = [], []
        for r in self.runs:
            f, bases = self.model.eval_split(v, r, self.lin_effects)
            rest.append(f[r.steady])
            cols.append(np.column_stack([bases[e][r.steady] for e in self.lin_effects])
                        if self.linear else np.zeros((int(r.steady.sum()), 0)))
        return np.concatenate(rest), np.concatenate(cols)

    def _solve(self, B: np.ndarray, y: np.ndarray) -> np.ndarray:
        if not self.linear:
            return np.zeros(0)
        norms = np.sqrt(np.einsum("ij,ij->j", B, B))
        norms[norms == 0] = 1.0
        Bs = B / norms
        lo = np.array([self.params[k].lower for k in self.linear]) * norms
        hi = np.array([self.params[k].upper for k in self.linear]) * norms
        if np.all(np.isinf(lo)) and np.all(np.isinf(hi)):
            # normal equations of the column-scaled regressors (few columns: cheap and well
            # conditioned unless regressors are collinear; lstsq on the small system).
            # einsum, not BLAS: a threaded BLAS stalls on tall-thin products under load.
            gram = np.einsum("ij,ik->jk", Bs, Bs)
            th = np.linalg.lstsq(gram, np.einsum("ij,i->j", Bs, y), rcond=1e-12)[0]
        else:
            th = lsq_linear(Bs, y, bounds=(lo, hi), method="bvls").x
        return th / norms

    def project(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(residual, linear parameters) at nonlinear coordinates ``x``."""
        self.n_evals += 1
        try:
            rest, B = self._split(self.values(x))
        except (FloatingPointError, ZeroDivisionError, OverflowError):
            rest, B = np.full_like(self.y, np.nan), np.zeros((self.y.size, len(self.linear)))
        y = self.y - rest
        if not np.all(np.isfinite(y)):  # a failed evaluation: a large, finite residual
            big = 1e3 * (np.abs(self.y).max() + 1.0)
            return np.full_like(self.y, big), np.zeros(len(self.linear))
        th = self._solve(B, y)
        return y - B @ th, th

    def residual(self, x: np.ndarray) -> np.ndarray:
        return self.project(x)[0]

    def all_values(self, x: np.ndarray) -> dict[str, float]:
        v = self.values(x)
        v.update(dict(zip(self.linear, self.project(x)[1])))
        return v

    def jacobian(self, v: dict[str, float]) -> tuple[np.ndarray, list[str]]:
        """d(residual)/d(parameter) in natural units for all varied parameters."""
        names = [c.name for c in self.coords] + self.linear
        cols = []
        for c in self.coords:
            p = v[c.name]
            h = FD_REL * (abs(p) if c.log else c.scale)
            hp, hm = min(h, c.upper - p), min(h, p - c.lower)
            hi_v, lo_v = dict(v), dict(v)
            hi_v[c.name], lo_v[c.name] = p + hp, p - hm
            f_hi = np.concatenate([self.model.eval(hi_v, r)[r.steady] for r in self.runs])
            f_lo = np.concatenate([self.model.eval(lo_v, r)[r.steady] for r in self.runs])
            self.n_evals += 2
            cols.append(-(f_hi - f_lo) / (hp + hm) if hp + hm > 0 else np.zeros_like(self.y))
        if self.linear:
            _, B = self._split(v)
            cols.extend(-B[:, j] for j in range(B.shape[1]))
        return (np.column_stack(cols) if cols else np.zeros((self.y.size, 0))), names


class ModelFitter:
    """Estimator: ``ModelFitter(model, ...).fit(runs) -> FitResult`` (settings only here;
    the last result is also kept as ``result_``).

    model: a :class:`Model` or an expression ``"a+b+c"``.
    multistart: number of starts (all polished), or "auto": up to 1 + 2 per effect whose
        surface is multimodal (hysteretic, backlash, delay), stopping at the noise floor.
    seed: random seed of the extra starts.
    max_nfev: function evaluations per start (least_squares' count, Jacobian excluded);
        None: 100 per nonlinear parameter.
    params: optional :class:`Parameters` overriding values, bounds or vary flags.
    solve_linear: solve the force effects' parameters by variable projection.
    method: ``least_squares`` method, "trf" (default; robust to rank-deficient Jacobians)
        or "dogbox".
    """

    def __init__(self, model: Model | str, *, multistart: int | str = "auto", seed: int = 0,
                 max_nfev: int | None = None, params: Parameters | None = None,
                 solve_linear: bool = True, method: str = "trf") -> None:
        self.model = model
        self.method = method
        self.multistart = multistart
        self.seed = seed
        self.max_nfev = max_nfev
        self.params = params
        self.solve_linear = solve_linear

    def _start_params(self, model: Model, summary: LoopSummary,
                      init: FitResult | Parameters | dict[str, float] | None
                      ) -> tuple[Parameters, set[str]]:
        p = model.make_params(runs=summary)
        warm: set[str] = set()
        if init is not None:
            for e in model.effects:       # added effects start where they change nothing
                for name, val in (e.neutral(summary) or {}).items():
                    p[f"{e.name}.{name}"].value = val
            src = init.params_ if isinstance(init, FitResult) else init
            vals = src.valuesdict() if isinstance(src, Parameters) else dict(src)
            for k, v in vals.items():
                if k in p:
                    p[k].value = float(np.clip(v, p[k].lower, p[k].upper))
                    warm.add(k)
        if self.params is not None:
            for k, q in self.params.items():
                if k not in p:
                    raise InputError(f"not a parameter of '{model.expr}'", field=k)
                p[k].lower, p[k].upper, p[k].vary = q.lower, q.upper, q.vary
                if np.isfinite(q.value):
                    p[k].value = q.value
        for k, q in p.items():
            if not np.isfinite(q.value):
                raise InputError("no starting value (give it in params)", field=k)
            q.value = float(np.clip(q.value, q.lower, q.upper))
        return p, warm

    def _n_starts(self, model: Model, prob: _Problem, warm: set[str]) -> int:
        if self.multistart != "auto":
            n = int(self.multistart)
            if n < 1:
                raise InputError("multistart must be >= 1 or 'auto'", field="multistart")
            return n
        new = {c.name.split(".")[0] for c in prob.coords if c.name not in warm}
        hard = [e for e in model.effects if e.name in new and e.needs_multistart]
        return 1 + 2 * len(hard)

    def _draw(self, prob: _Problem, x0: np.ndarray, lb: np.ndarray, ub: np.ndarray,
              rng: np.random.Generator, warm: set[str]) -> np.ndarray:
        x = x0.copy()
        for i, c in enumerate(prob.coords):
            if c.name in warm:
                continue
            if c.log:
                x[i] = x0[i] + rng.normal(0.0, np.log(3.0))
            elif np.isfinite(c.lower) and np.isfinite(c.upper):
                span = c.upper - c.lower
                x[i] = c.to_x(rng.uniform(c.lower + 0.05 * span, c.upper - 0.05 * span))
            else:
                x[i] = x0[i] + rng.normal(0.0, 1.0)
        return np.clip(x, lb, ub)

    def _multistart(self, model: Model, prob: _Problem, x0: np.ndarray, lb: np.ndarray,
                    ub: np.ndarray, warm: set[str], runs: list[RunData],
                    costs: list[float], floor: float | None) -> tuple[np.ndarray, bool, str]:
        """Polish the first start; if its NRMSE is above STOP_FACTOR x the noise floor, polish
        further starts, each the best (by initial cost) of SCREEN random draws."""
        rng = np.random.default_rng(self.seed)
        max_nfev = self.max_nfev or 100 * len(x0)
        n_starts = self._n_starts(model, prob, warm)
        auto = self.multistart == "auto"
        y2 = float(prob.y @ prob.y)
        if not (auto and n_starts > 1):
            floor = np.nan
        elif floor is None:
            floor = period_shift_floor(runs)
        best = None
        for k in range(n_starts):
            if k == 0:
                xs = x0
            else:
                draws = [self._draw(prob, x0, lb, ub, rng, warm) for _ in range(SCREEN)]
                xs = min(draws, key=lambda x: float(np.sum(prob.residual(x) ** 2)))
            sol = least_squares(prob.residual, xs, bounds=(lb, ub), method=self.method,
                                x_scale=1.0, diff_step=1e-6, max_nfev=max_nfev,
                                ftol=FTOL, xtol=XTOL)
            costs.append(float(sol.cost))
            if best is None or sol.cost < best.cost:
                best = sol
            if auto and np.sqrt(2 * best.cost / y2) <= STOP_FACTOR * floor:
                break   # at the noise floor: no start can do significantly better
        assert best is not None
        return best.x, bool(best.success), str(best.message)

    def fit(self, runs: RunData | Sequence[RunData], validation: Sequence[RunData] | None = None,
            init: FitResult | Parameters | dict[str, float] | None = None,
            floor: float | None = None) -> FitResult:
        """Fit the model to ``runs`` (steady samples), report NRMSE on ``validation``.

        ``init``: a previous FitResult (or parameter values) to start from; parameters it
        names keep their values in every start, and added modifier or input effects
        start at their neutral values (no change), so a refit with one extra effect is
        cheap and cannot end worse than the previous fit. ``floor``: the runs' noise-floor
        NRMSE, where multi-start "auto" stops (module docstring).

        BLAS runs on one thread meanwhile (:func:`one_blas_thread`).
        """
        with one_blas_thread():
            return self._fit(runs, validation, init, floor)

    def _fit(self, runs: RunData | Sequence[RunData], validation: Sequence[RunData] | None,
             init: FitResult | Parameters | dict[str, float] | None,
             floor: float | None) -> FitResult:
        model = Model.parse(self.model)
        runs = as_runs(runs, "runs")
        val = as_runs(validation or [], "validation")
        if not runs:
            raise InputError("no runs to fit", field="runs")
        summary = LoopSummary.from_runs(runs)
        params, warm = self._start_params(model, summary, init)
        prob = _Problem(model, runs, params, summary, self.solve_linear)
        n = len(prob.coords)
        x0 = np.array([c.to_x(params[c.name].value) for c in prob.coords])
        bnds = [c.bounds() for c in prob.coords]
        lb, ub = np.array([b[0] for b in bnds]), np.array([b[1] for b in bnds])
        # trf stalls on a start exactly at a bound (Coleman-Li scaling vanishes there):
        # start a little inside (NUDGE in scaled units, at most 1 % of the range)
        x_raw = np.clip(x0, lb, ub)
        nudge = np.minimum(NUDGE, 0.01 * (ub - lb))
        x0 = np.clip(x0, lb + nudge, ub - nudge)
        costs: list[float] = []
        if n == 0:
            x_best, ok, msg = x0, True, "linear least squares (exact)"
            costs.append(0.5 * float(np.sum(prob.residual(x0) ** 2)))
        else:
            x_best, ok, msg = self._multistart(model, prob, x0, lb, ub, warm, runs, costs, floor)
            if init is not None:  # keep the warm start itself if no start beat it
                c_raw = 0.5 * float(np.sum(prob.residual(x_raw) ** 2))
                if c_raw < min(costs):
                    x_best, msg = x_raw, msg + "; the warm start was not improved on"
        v = prob.all_values(x_best)
        out = params.copy()
        for k, p in out.items():
            p.value = float(np.clip(v[k], p.lower, p.upper))
            p.stderr = None
        r = prob.residual(x_best)
        ssr = float(r @ r)
        J, names = prob.jacobian(out.valuesdict())
        cov, note = covariance(J, ssr)
        se = np.sqrt(np.abs(np.diag(cov))) if names else np.zeros(0)
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(se, se) if names else cov
        stderr = {k: float(s) for k, s in zip(names, se)}
        for k, s in stderr.items():
            out[k].stderr = s
        fit_n, fit_per = nrmse(model, out, runs)
        val_n, val_per = nrmse(model, out, val) if val else (None, {})
        self.result_ = FitResult(
            model=model, params_=out, varied_=tuple(names), stderr_=stderr, correlation_=corr,
            nrmse_=fit_n, run_nrmse_=fit_per, validation_nrmse_=val_n,
            validation_run_nrmse_=val_per, n_evals_=prob.n_evals, success_=ok,
            message_=msg + note, n_samples_=int(prob.y.size), ssr_=ssr,
            start_costs_=tuple(costs), fit_runs_=tuple(run_labels(runs)),
            validation_runs_=tuple(run_labels(val)))
        return self.result_
