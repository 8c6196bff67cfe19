"""Stage-2 updating: a joint law's nonlinear parameters from constant-force FRFs (seed 000 Eq. 9).

Residual (Eq. 9): r_i = (alpha_model(w_i) - alpha_test(w_i)) / |alpha_test(w_i)| over the
fitted steps (each complex residual as its real and imaginary parts; the harmonic-1
accelerance of every sensor), minimised by ``scipy.optimize.least_squares`` (trf,
2-point Jacobian, scaled by the Jacobian's columns) in ln p for parameters that are positive, within the vocabulary's
bounds and, for Richard-Abbott, E_p < E_e (kp < ke, Eq. 9's constraint). The steps
around mode 1 are fitted and those around mode 2 validate (seed 000's workflow): a step
belongs to the mode whose linear natural frequency is nearest (in log frequency).

Uncertainty: the covariance of the linearised estimate,
(J^T J)^-1 J^T S J (J^T J)^-1 with S the variance of each residual from the set's
``response_std`` (the phasor's std over |alpha_test| |F|, split evenly between the real
and imaginary part), which holds when the residuals' spread is the measurement noise;
without stated stds, s^2 (J^T J)^-1 with s^2 the residual variance. Standard errors of
ln p are converted to p (p x se). The validation error is the Eq. 9 RMS on the mode-2
steps.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from labjoint.errors import InputError
from labjoint.signal.frfset import FrfSet
from labjoint.structure.hbm import ConvergenceError
from labjoint.structure.law import JointLaw
from labjoint.structure.predict import FrfPredictor

RA_DEFAULT = ("richard_abbott.kp", "richard_abbott.F_y", "richard_abbott.n")
KP_MARGIN = 1.0 - 1e-6
DIFF_STEP = 1e-4
#: positive parameters stay within this factor of their start (stage 2's physical bounds)
SCALE_RANGE = 1e3
#: shape parameters' useful ranges
SHAPE_BOUNDS = {"richard_abbott.n": (0.5, 20.0), "iwan.chi": (-0.99, 0.99), "iwan.beta": (0.0, 50.0),
                "asymmetric_slip.asym": (-0.95, 0.95)}
#: a trial point where harmonic balance fails answers this multiple of the last residual
NO_SOLUTION = 3.0
#: a coordinate within this fraction of its range from a bound is at the bound
BOUND_TOL = 1e-4
#: a Jacobian whose condition number exceeds this has a singular covariance
COND_MAX = 1e8


def split_by_mode(frequencies_hz: np.ndarray, natural_hz: Sequence[float]) -> np.ndarray:
    """Index (0-based) of the nearest natural frequency (in log frequency) of each step.

    >>> split_by_mode(np.array([27.0, 30.0, 170.0]), [28.5, 177.0]).tolist()
    [0, 0, 1]
    """
    lf = np.log(np.asarray(frequencies_hz, float))[:, None]
    return np.argmin(np.abs(lf - np.log(np.asarray(natural_hz, float))[None, :]), axis=1)


def eq9_residual(model: np.ndarray, fs: FrfSet) -> np.ndarray:
    """Eq. 9 residuals, harmonic 1, every sensor: real and imaginary parts, stacked."""
    a_m = model[:, :, 0] / fs.force[:, None]
    a_t = fs.accelerance(1)
    r = (a_m - a_t) / np.abs(a_t)
    return np.concatenate([r.real.ravel(), r.imag.ravel()])


def eq9_sigma(fs: FrfSet) -> np.ndarray:
    """Std of each Eq. 9 residual component from ``response_std``."""
    s = fs.response_std[:, :, 0] / np.abs(fs.response[:, :, 0]) / np.sqrt(2)
    return np.concatenate([s.ravel(), s.ravel()])


@dataclass
class LawFit:
    """Fitted law, its parameters' values and standard errors, and the search's trace.

    ``converged`` is True only when the search stopped inside the bounds with a regular
    covariance; otherwise ``flags`` say why (a parameter at a bound, a singular
    covariance, a non-finite residual) and the standard errors are NaN (never 0.0)."""

    law: JointLaw
    names: tuple[str, ...]
    values: dict[str, float]
    stderr: dict[str, float]
    correlation: np.ndarray
    cost: float
    n_evals: int
    history: list[dict[str, Any]] = field(default_factory=list)
    message: str = ""
    converged: bool = False
    flags: list[str] = field(default_factory=list)


def physical_bounds(name: str, value: float, ke: float | None = None) -> tuple[float, float]:
    """Physical bounds of a law parameter around its start ``value`` (SI): shape exponents
    within their useful range, Iwan's chi and beta within the vocabulary's, everything
    positive within ``SCALE_RANGE`` of its start, kp below ke (Eq. 9's E_p < E_e).

    >>> physical_bounds("richard_abbott.n", 3.6)
    (0.5, 20.0)
    """
    if name in SHAPE_BOUNDS:
        return SHAPE_BOUNDS[name]
    if name == "richard_abbott.kp" and ke is not None:
        return (ke / SCALE_RANGE ** 2, KP_MARGIN * ke)
    if value > 0:
        return (value / SCALE_RANGE, value * SCALE_RANGE)
    return (-np.inf, np.inf)


def _coords(law: JointLaw, names: Sequence[str], start: dict[str, float] | None,
            scale_range: float | None = None, typical: dict[str, float] | None = None,
            strict: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Start, bounds, log flags and scales of the searched coordinates: ln p for positive
    parameters (an e-fold is one unit), p / scale for signed ones (scale: ``typical`` or
    the start's magnitude), so every coordinate moves by O(1) and a step of the search
    cannot throw a parameter ten decades away. ``strict``: a start outside the bounds is
    an InputError (a user's start), else it is clipped (a computed start)."""
    p = law.model.make_params(values={**law.params, **(start or {})})
    typical = typical or {}
    x0, lo, hi, logs, sc = [], [], [], [], []
    known = set(law.model.param_names)
    ke = p["richard_abbott.ke"].value if "richard_abbott.ke" in known and "richard_abbott.ke" not in names else None
    for nm in names:
        if nm not in known:
            raise InputError(f"not a parameter of the joint law '{law.model.expr}' "
                             f"({', '.join(law.params)})", field=nm)
        q = p[nm]
        v = float(q.value)
        b_lo, b_hi = physical_bounds(nm, v, ke) if scale_range is None else \
            ((v / scale_range, v * scale_range) if v > 0 and q.lower >= 0 else SHAPE_BOUNDS.get(nm, (-np.inf, np.inf)))
        if nm == "richard_abbott.kp" and ke is not None:
            b_hi = min(b_hi, KP_MARGIN * ke)
        lower, upper = max(q.lower, b_lo), min(q.upper, b_hi)
        if not lower <= v <= upper:
            if strict:
                raise InputError(f"start {v:.6g} is outside the bounds [{lower:.6g}, {upper:.6g}]; "
                                 "set a start inside them (--set)", field=nm)
            v = float(np.clip(v, lower, upper))
        lg = q.lower >= 0 and v > 0 and nm not in SHAPE_BOUNDS
        scale = 1.0 if lg else float(typical.get(nm) or (abs(v) if v != 0 else 1.0))
        logs.append(lg)
        sc.append(scale)
        x0.append(np.log(v) if lg else v / scale)
        lo.append(np.log(lower) if lg and lower > 0 else (-np.inf if lg else lower / scale))
        hi.append(np.log(upper) if lg else upper / scale)
    x0, lo, hi, logs, sc = (np.array(a) for a in (x0, lo, hi, logs, sc))
    span = hi - lo
    pad = np.where(np.isfinite(span), 1e-9 * span, 1e-9)
    return np.clip(x0, lo + pad, hi - pad), lo, hi, logs.astype(bool), sc


def _covariance(J: np.ndarray, r: np.ndarray, sigma: np.ndarray | None, n: int) -> np.ndarray | None:
    """Covariance of the coordinates, or None when J^T J is singular (module docstring)."""
    if J.size == 0 or not np.all(np.isfinite(J)):
        return None
    sv = np.linalg.svd(J, compute_uv=False)
    if sv.size < n or sv[-1] <= COND_MAX ** -1 * sv[0]:
        return None
    inv = np.linalg.inv(J.T @ J)
    if sigma is not None and np.all(np.isfinite(sigma)) and np.any(sigma > 0):
        return inv @ (J.T * sigma ** 2) @ J @ inv
    dof = max(r.size - n, 1)
    return inv * float(r @ r) / dof


def fit_law(law: JointLaw, names: Sequence[str], residual: Callable[[JointLaw], np.ndarray],
            sigma: np.ndarray | None = None, start: dict[str, float] | None = None,
            max_nfev: int | None = None, scale_range: float | None = None,
            typical: dict[str, float] | None = None, strict: bool = False,
            jacobian: Callable[[JointLaw], np.ndarray] | None = None) -> LawFit:
    """Least squares of ``residual(law)`` over the law parameters ``names`` (module
    docstring); ``scale_range``: positive parameters kept within this factor of their start
    (default: :func:`physical_bounds`); ``typical``: the scale of signed parameters;
    ``jacobian(law)``: d residual / d p (columns in the order of ``names``), else
    finite differences (also where it fails to converge)."""
    names = tuple(names)
    x0, lo, hi, logs, sc = _coords(law, names, start, scale_range, typical, strict)
    history: list[dict[str, Any]] = []

    def values(x: np.ndarray) -> np.ndarray:
        return np.where(logs, np.exp(np.where(logs, x, 0.0)), x * sc)

    def law_at(x: np.ndarray) -> JointLaw:
        return law.with_params(**{**(start or {}), **dict(zip(names, values(x).tolist()))})

    last: list[np.ndarray] = []

    def fun(x: np.ndarray) -> np.ndarray:
        try:
            r = residual(law_at(x))
        except ConvergenceError:
            if not last:
                raise
            r = NO_SOLUTION * last[0]          # a trial the solver cannot follow: rejected
        last[:] = [r]
        history.append({"parameters": dict(zip(names, values(x).tolist())), "cost": float(r @ r) / 2})
        return r

    jac: Any = "2-point"
    if jacobian is not None:
        def jac(x: np.ndarray) -> np.ndarray:
            dpdx = np.where(logs, values(x), sc)
            try:
                return jacobian(law_at(x)) * dpdx[None, :]
            except (ConvergenceError, np.linalg.LinAlgError):     # finite differences instead
                r0 = fun(x)
                cols = []
                for i in range(x.size):
                    h = DIFF_STEP * max(1.0, abs(x[i])) * (1 if x[i] + DIFF_STEP < hi[i] else -1)
                    cols.append((fun(x + h * np.eye(x.size)[i]) - r0) / h)
                return np.column_stack(cols)
    sol = least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", diff_step=DIFF_STEP,
                        x_scale=1.0, max_nfev=max_nfev or 15 * len(names))
    v = values(sol.x)
    flags = []
    span = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    at = [nm for nm, x, a, b, s in zip(names, sol.x, lo, hi, span)
          if (np.isfinite(a) and x - a < BOUND_TOL * s) or (np.isfinite(b) and b - x < BOUND_TOL * s)]
    if at:
        flags.append("at a bound: " + ", ".join(at))
    if not np.all(np.isfinite(sol.fun)):
        flags.append("non-finite residual")
    cov = _covariance(sol.jac, sol.fun, sigma, len(names)) if np.all(np.isfinite(sol.fun)) else None
    if cov is None:
        flags.append("singular covariance: the data do not determine every parameter")
    if sol.status <= 0:
        flags.append(f"stopped without converging ({sol.message})")
    if cov is None or flags:
        se = np.full(len(names), np.nan)
        corr = np.full((len(names), len(names)), np.nan)
    else:
        se_x = np.sqrt(np.clip(np.diag(cov), 0, None))
        se = np.where(logs, v * se_x, se_x * sc)
        d = np.sqrt(np.diag(cov))
        corr = cov / np.outer(d, d) if np.all(d > 0) else np.full_like(cov, np.nan)
    return LawFit(law_at(sol.x), names, dict(zip(names, v.tolist())), dict(zip(names, se.tolist())),
                  corr, float(sol.cost), int(sol.nfev), history, str(sol.message),
                  converged=not flags, flags=flags)


@dataclass
class Stage2Result:
    """Stage-2 update: the fit, the steps used, the fit and validation errors (Eq. 9 RMS)."""

    fit: LawFit
    fit_steps: int
    validation_steps: int
    error_fit: float
    error_validation: float | None
    natural_hz: list[float]
    layer: dict[str, float] = field(default_factory=dict)
    time_s: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        f = self.fit
        return {"parameters": {k: {"value": f.values[k], "stderr": f.stderr[k]} for k in f.names},
                "converged": f.converged, "flags": list(f.flags),
                "layer": self.layer, "objective": "seed 000 Eq. 9 (relative accelerance residual)",
                "error_fit_rms": self.error_fit, "error_validation_rms": self.error_validation,
                "fit_steps": self.fit_steps, "validation_steps": self.validation_steps,
                "natural_frequencies_hz": self.natural_hz, "evaluations": f.n_evals,
                "history": f.history, "correlation": f.correlation.tolist(),
                "message": f.message, "time_s": self.time_s}


def _layer_values(predictor: FrfPredictor, fit: LawFit) -> dict[str, float]:
    """E_p, S_Y (Pa) of a Richard-Abbott layer joint from kp, F_y (seed 000 Eq. 2)."""
    j = predictor.structure.joints[0]
    if j.layer is None or "richard_abbott" not in fit.law.model.names:
        return {}
    A, h = j.layer.area(j.radius_m), j.layer.thickness_m
    out = {}
    for nm, key, conv in (("richard_abbott.kp", "E_p_pa", h / A), ("richard_abbott.F_y", "S_Y_pa", 1 / A),
                          ("richard_abbott.ke", "E_e_pa", h / A), ("richard_abbott.n", "n", 1.0)):
        if nm in fit.values:
            out[key] = fit.values[nm] * conv
            out[key + "_stderr"] = fit.stderr[nm] * conv
    return out


def update_nonlinear(predictor: FrfPredictor, frfset: FrfSet, parameters: Sequence[str] | None = None,
                     law: JointLaw | None = None, max_nfev: int | None = None,
                     fit_modes: Sequence[int] = (1,)) -> Stage2Result:
    """Fit the law's ``parameters`` (default E_p, S_Y, n: kp, F_y, n) on the steps around
    mode 1, validate around mode 2 (module docstring); ``fit_modes`` (1-based) fits on
    the steps around those modes instead and validates on the others."""
    t0 = time.perf_counter()
    law = law or predictor.law
    names = tuple(parameters) if parameters else tuple(
        RA_DEFAULT if "richard_abbott" in law.model.names else
        [p for p in law.params if p != "richard_abbott.ke"])
    nat = predictor.natural_frequencies(max(2, *fit_modes))
    mode = split_by_mode(frfset.frequencies_hz, nat)
    fitted = np.isin(mode, np.asarray(fit_modes, int) - 1)
    fit_set = frfset.subset(fitted)
    if len(fit_set) == 0 or fit_set.frequencies_hz.size < len(names):
        raise InputError(f"need at least {len(names)} steps around mode 1 ({nat[0]:.4g} Hz) "
                         "to fit", field="frequencies_hz")
    val = ~fitted
    def jacobian(lw: JointLaw) -> np.ndarray:
        _, d = predictor.predict_jacobian(fit_set, lw, names, 1)
        a_t = fit_set.accelerance(1)
        cols = [d[:, :, 0, j] / fit_set.force[:, None] / np.abs(a_t) for j in range(len(names))]
        return np.column_stack([np.concatenate([c.real.ravel(), c.imag.ravel()]) for c in cols])

    fit = fit_law(law, names, lambda lw: eq9_residual(predictor.predict(fit_set, lw, 1), fit_set),
                  eq9_sigma(fit_set), max_nfev=max_nfev, strict=True, jacobian=jacobian)
    rms = lambda r: float(np.sqrt(np.mean(r ** 2)))  # noqa: E731
    e_fit = rms(eq9_residual(predictor.predict(fit_set, fit.law, 1), fit_set))
    e_val = None
    if val.any():
        vs = frfset.subset(val)
        e_val = rms(eq9_residual(predictor.predict(vs, fit.law, 1), vs))
    return Stage2Result(fit, len(fit_set), int(val.sum()), e_fit, e_val, nat.tolist(),
                        _layer_values(predictor, fit), time.perf_counter() - t0)
