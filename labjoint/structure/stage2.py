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
from labjoint.structure.law import JointLaw
from labjoint.structure.predict import FrfPredictor

RA_DEFAULT = ("richard_abbott.kp", "richard_abbott.F_y", "richard_abbott.n")
KP_MARGIN = 1.0 - 1e-6
DIFF_STEP = 1e-4


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
    """Fitted law, its parameters' values and standard errors, and the search's trace."""

    law: JointLaw
    names: tuple[str, ...]
    values: dict[str, float]
    stderr: dict[str, float]
    correlation: np.ndarray
    cost: float
    n_evals: int
    history: list[dict[str, Any]] = field(default_factory=list)
    message: str = ""


def _coords(law: JointLaw, names: Sequence[str], start: dict[str, float] | None,
            scale_range: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Start, bounds and log flags of the searched coordinates."""
    p = law.model.make_params(values={**law.params, **(start or {})})
    x0, lo, hi, logs = [], [], [], []
    for nm in names:
        if nm not in p:
            raise InputError(f"not a parameter of the joint law '{law.model.expr}' "
                             f"({', '.join(law.params)})", field=nm)
        q = p[nm]
        upper = q.upper
        if nm == "richard_abbott.kp" and "richard_abbott.ke" not in names:
            upper = min(upper, KP_MARGIN * p["richard_abbott.ke"].value)   # E_p < E_e (Eq. 9)
        v = float(np.clip(q.value, q.lower, upper))
        lg = q.lower >= 0 and v > 0
        logs.append(lg)
        x0.append(np.log(v) if lg else v)
        lo.append(np.log(q.lower) if lg and q.lower > 0 else (-np.inf if lg else q.lower))
        hi.append(np.log(upper) if lg else upper)
    x0, lo, hi, logs = np.array(x0), np.array(lo), np.array(hi), np.array(logs)
    if scale_range is not None:
        w = np.log(scale_range)
        lo = np.where(logs, np.maximum(lo, x0 - w), lo)
        hi = np.where(logs, np.minimum(hi, x0 + w), hi)
    return np.clip(x0, lo + 1e-12, hi - 1e-12), lo, hi, logs


def fit_law(law: JointLaw, names: Sequence[str], residual: Callable[[JointLaw], np.ndarray],
            sigma: np.ndarray | None = None, start: dict[str, float] | None = None,
            max_nfev: int | None = None, scale_range: float | None = None) -> LawFit:
    """Least squares of ``residual(law)`` over the law parameters ``names`` (module
    docstring); ``scale_range``: positive parameters kept within this factor of their start."""
    names = tuple(names)
    x0, lo, hi, logs = _coords(law, names, start, scale_range)
    history: list[dict[str, Any]] = []

    def law_at(x: np.ndarray) -> JointLaw:
        v = np.where(logs, np.exp(np.minimum(x, 700.0)), x)
        return law.with_params(**{**(start or {}), **dict(zip(names, v.tolist()))})

    def fun(x: np.ndarray) -> np.ndarray:
        r = residual(law_at(x))
        v = np.where(logs, np.exp(np.minimum(x, 700.0)), x)
        history.append({"parameters": dict(zip(names, v.tolist())), "cost": float(r @ r) / 2})
        return r

    sol = least_squares(fun, x0, bounds=(lo, hi), method="trf", diff_step=DIFF_STEP,
                        x_scale="jac", max_nfev=max_nfev or 15 * len(names))
    J, r = sol.jac, sol.fun
    JtJ = J.T @ J
    try:
        inv = np.linalg.inv(JtJ)
    except np.linalg.LinAlgError:
        inv = np.linalg.pinv(JtJ)
    if sigma is not None and np.all(np.isfinite(sigma)) and np.any(sigma > 0):
        cov = inv @ (J.T * sigma ** 2) @ J @ inv
    else:
        dof = max(r.size - len(names), 1)
        cov = inv * float(r @ r) / dof
    se_x = np.sqrt(np.clip(np.diag(cov), 0, None))
    v = np.where(logs, np.exp(np.minimum(sol.x, 700.0)), sol.x)
    se = np.where(logs, v * se_x, se_x)
    d = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    return LawFit(law_at(sol.x), names, dict(zip(names, v.tolist())), dict(zip(names, se.tolist())),
                  cov / np.outer(d, d), float(sol.cost), int(sol.nfev), history, str(sol.message))


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
                     law: JointLaw | None = None, max_nfev: int | None = None) -> Stage2Result:
    """Fit the law's ``parameters`` (default E_p, S_Y, n: kp, F_y, n) on the steps around
    mode 1, validate around mode 2 (module docstring)."""
    t0 = time.perf_counter()
    law = law or predictor.law
    names = tuple(parameters) if parameters else tuple(
        RA_DEFAULT if "richard_abbott" in law.model.names else
        [p for p in law.params if p != "richard_abbott.ke"])
    nat = predictor.natural_frequencies(2)
    mode = split_by_mode(frfset.frequencies_hz, nat)
    fit_set = frfset.subset(mode == 0)
    if len(fit_set) == 0 or fit_set.frequencies_hz.size < len(names):
        raise InputError(f"need at least {len(names)} steps around mode 1 ({nat[0]:.4g} Hz) "
                         "to fit", field="frequencies_hz")
    val = mode != 0
    fit = fit_law(law, names, lambda lw: eq9_residual(predictor.predict(fit_set, lw, 1), fit_set),
                  eq9_sigma(fit_set), max_nfev=max_nfev)
    rms = lambda r: float(np.sqrt(np.mean(r ** 2)))  # noqa: E731
    e_fit = rms(eq9_residual(predictor.predict(fit_set, fit.law, 1), fit_set))
    e_val = None
    if val.any():
        vs = frfset.subset(val)
        e_val = rms(eq9_residual(predictor.predict(vs, fit.law, 1), vs))
    return Stage2Result(fit, len(fit_set), int(val.sum()), e_fit, e_val, nat.tolist(),
                        _layer_values(predictor, fit), time.perf_counter() - t0)
