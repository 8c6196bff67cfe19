"""Identification by simulation error (output error) and forward prediction.

The force applied to the structure is the input, the measured displacement the output:
a model with inertia is simulated from the force (:mod:`labjoint.models.simulate`) and
its parameters are those that minimise the simulation error of the displacement over the
judged samples of every record, pooled (NRMSE of the displacement, design.md's NRMSE with
the output in place of the force).

- Records are prepared as the record kind (:mod:`labjoint.compare.kinds.record`): the
  excitation is found, and with it whether the record is periodic.
- Start: the equation-error fit of the same model on the same records (the force
  balance along the measured history, :func:`labjoint.compare.api.fit_report`), which
  needs only the data's loop quantities; for a candidate, that or the same with the
  smaller model's optimum for its parameters, whichever simulates the records better
  (the smaller model's compromise can sit far from the larger one's). Where it is not a stable oscillator (mass or
  stiffness <= 0) or its simulation diverges on the first record, the mass, stiffness
  and damping come from the records' FRF instead (:mod:`labjoint.compare.sim_start`),
  the other parameters kept. The user's ``start`` values (``--start name=value``) go on
  top, and ``bounds`` (``--bound name=lo:hi``) narrow the vocabulary's; a start outside
  its bounds is refused.
- Search: ``scipy.optimize.least_squares`` (trf, 2-point Jacobian) in scaled coordinates,
  ln(p / p0) for the effects' positive scale parameters and the mass (it must stay > 0),
  (p - p0) / s otherwise, s the effect's typical magnitude on these data
  (:meth:`labjoint.models.effects.base.Effect.scales`: a term starting at zero still moves
  on the data's scale), within the bounds; standard errors from the Jacobian at the
  optimum (:func:`labjoint.models.covariance.covariance`, NaN where undetermined), which
  assume independent residuals.
- Divergence: a fit whose simulation is not finite on a record, or whose parameters are
  not, is refused (InputError naming the record and the parameters), never reported or
  saved with a NaN.
- The simulation starts at rest at each record's first sample; a ``periodic`` record is
  simulated to its periodic steady state. A displacement sensor's DC level is arbitrary,
  so the prediction is compared after adding the constant that best matches it to the
  measurement over the judged samples (the mean residual, solved exactly; taking the
  first sample as zero instead biased the parameters by the noise of that one sample).
  Judged samples: those of the record kind (after the warm-up).
- Noise floor: the record's displacement noise (period scatter or the difference method)
  and its force noise passed through the model's linear part (the force is the
  simulation's input: sigma_F^2 times the mean of |H|^2 over 0..fs/2, H = 1 / (k - m w^2
  + i c w) of the fitted inertia, viscous and linear_stiffness), over the rms of its
  judged displacement.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from labjoint.compare.flags import measurement_flags
from labjoint.compare.identifiability import band_warnings
from labjoint.compare.kinds import prepare
from labjoint.compare.kinds.record import RecordMeasurement
from labjoint.compare.measurement import Measurement
from labjoint.compare.sim_start import aligned, diverges, record_output, start_values
from labjoint.errors import InputError
from labjoint.models import LoopSummary, Model, Parameters
from labjoint.models.asymmetry import EVEN, asymmetry
from labjoint.models.covariance import covariance
from labjoint.models.effects import get_effect
from labjoint.models.result import parameter_flags, parameter_table
from labjoint.models.scores import nrmse_from_sums, pooled_nrmse
from labjoint.models.simulate import DEFAULT_SUBSTEPS, check_simulable, simulate

MAX_NFEV_PER_PARAM = 60
FORMAT = "labjoint-model/1"


@dataclass
class Prediction:
    """A model simulated on one record: predicted and measured displacement (m)."""

    name: str
    predicted: np.ndarray
    measured: np.ndarray
    judged: np.ndarray
    noise_std_m: float = float("nan")
    fs: float = float("nan")

    @property
    def residual(self) -> np.ndarray:
        return (self.measured - self.predicted)[self.judged]

    @property
    def sse(self) -> float:
        return float(self.residual @ self.residual)

    @property
    def sso(self) -> float:
        """Sum of squares of the judged measured output about its mean (its DC is arbitrary)."""
        y = self.measured[self.judged]
        y = y - float(np.mean(y))
        return float(y @ y)

    @property
    def rmse(self) -> float:
        return float(np.sqrt(self.sse / max(int(self.judged.sum()), 1)))

    @property
    def nrmse(self) -> float:
        return nrmse_from_sums(self.sse, self.sso)

    def to_dict(self) -> dict[str, Any]:
        return {"run": self.name, "rmse": self.rmse, "nrmse": self.nrmse,
                "noise_std_m": self.noise_std_m, "samples": int(self.judged.sum())}


def output_noise(params: Parameters | dict[str, float], m: RecordMeasurement) -> float:
    """The displacement noise a simulation error cannot go below (m): the record's own
    and its force noise through the model's linear part (module docstring)."""
    noise = m.noise()
    val = {k: float(getattr(v, "value", v)) for k, v in params.items()}
    mass, c, k = val.get("inertia.m", 0.0), val.get("viscous.c", 0.0), val.get("linear_stiffness.k", 0.0)
    var = noise.displacement_std ** 2
    if mass > 0 and np.isfinite(noise.force_std):
        w = 2 * np.pi * np.linspace(0.0, 0.5 * m.fs, 65537)
        with np.errstate(divide="ignore", invalid="ignore"):
            h2 = 1.0 / np.abs(k - mass * w * w + 1j * c * w) ** 2
        h2 = h2[np.isfinite(h2)]
        if h2.size:
            var += noise.force_std ** 2 * float(np.mean(h2))
    return float(np.sqrt(var))


def predict_record(model: Model, params: Parameters | dict[str, float], m: RecordMeasurement,
                   *, periodic: bool = False, substeps: int = DEFAULT_SUBSTEPS) -> Prediction:
    """Simulate ``model`` on the record's force and compare with its displacement."""
    y, judged = record_output(m)
    pred = simulate(model, params, m.data.force, m.fs, substeps=substeps, periodic=periodic)
    pred = aligned(pred, y, judged)
    return Prediction(m.name, pred, y, judged, output_noise(params, m), m.fs)


def displacement_floor(preds: list[Prediction]) -> float:
    """The noise floor of simulation error: the records' displacement noise over the rms
    of their judged displacement, pooled."""
    num = sum(p.noise_std_m ** 2 * p.judged.sum() for p in preds if np.isfinite(p.noise_std_m))
    den = sum(p.sso for p in preds)
    return float(np.sqrt(num / den)) if den > 0 else float("nan")


@dataclass
class SimulationFit:
    """An output-error fit: the model, its parameters with standard errors, the start it
    came from, and the predictions on the fit and validation records."""

    model: Model
    params: Parameters
    stderr: dict[str, float]
    start: dict[str, float]
    fit: list[Prediction]
    validation: list[Prediction] = field(default_factory=list)
    periodic: bool = False
    substeps: int = DEFAULT_SUBSTEPS
    n_evals: int = 0
    message: str = ""
    warnings: list[str] = field(default_factory=list)
    #: the user's likely mistakes in the records (:mod:`labjoint.compare.flags`)
    measurement_flags: list[dict[str, Any]] = field(default_factory=list)

    def nrmse(self, which: str = "fit") -> float:
        ps = self.fit if which == "fit" else self.validation
        return pooled_nrmse([p.sse for p in ps], [p.sso for p in ps])

    def noise_floor(self) -> float:
        """The displacement noise over the rms of the judged displacement, pooled."""
        return displacement_floor(self.fit)

    def model_dict(self) -> dict[str, Any]:
        """What ``--out MODEL.json`` holds: effects by name with parameters, the structure
        (an undetermined standard error is null, with the parameter's flag)."""
        pars = parameter_table(self.params, self.stderr, self.flags())
        return {"format": FORMAT, "model": self.model.expr, "structure": "sdof",
                "input": "force_N", "output": "displacement_m", "substeps": self.substeps,
                "parameters": pars}

    def flags(self) -> dict[str, str]:
        """Parameters whose standard error is undetermined or exceeds the value."""
        return parameter_flags({k: p.value for k, p in self.params.items()}, self.stderr)

    def asymmetry(self) -> list[dict[str, Any]]:
        """The even effects' asymmetry at the largest judged displacement amplitude."""
        if not any(n in EVEN for n in self.model.names):
            return []
        U = max((0.5 * float(np.ptp(p.measured[p.judged])) for p in self.fit if p.judged.any()),
                default=0.0)
        return asymmetry(self.model, self.params.valuesdict(), U)

    def to_dict(self) -> dict[str, Any]:
        d = self.model_dict()
        d.update(flags=self.flags(), asymmetry=self.asymmetry())
        d.update(error="simulation", kind="record", nrmse=self.nrmse(),
                 noise_floor=self.noise_floor(),
                 rmse=float(np.sqrt(sum(p.sse for p in self.fit)
                                    / max(sum(int(p.judged.sum()) for p in self.fit), 1))),
                 runs=[p.to_dict() for p in self.fit],
                 validation_runs=[p.to_dict() for p in self.validation],
                 nrmse_validation=self.nrmse("validation") if self.validation else None,
                 start=self.start, n_evals=self.n_evals, message=self.message,
                 warnings=list(self.warnings))
        if self.measurement_flags:
            d["measurement_flags"] = list(self.measurement_flags)
        return d


class _Scaled:
    """Scaled coordinates of the varied parameters (module docstring)."""

    def __init__(self, model: Model, start: Parameters, summary: LoopSummary | None = None) -> None:
        self.names, self.p0, self.log, self.s = [], [], [], []
        logs = {f"{e.name}.{p}" for e in model.effects for p in get_effect(e.name).log_params}
        logs.add("inertia.m")
        typical: dict[str, float] = {}
        if summary is not None:
            for e in model.effects:
                guess = {p.name: start[f"{e.name}.{p.name}"].value for p in e.params}
                try:
                    sc = e.scales(summary, guess)
                except (ValueError, ZeroDivisionError, FloatingPointError):
                    sc = {}
                typical.update({f"{e.name}.{k}": abs(float(v)) for k, v in sc.items()})
        for k, p in start.items():
            self.names.append(k)
            self.p0.append(p.value)
            self.log.append(k in logs and p.value > 0)
            t = typical.get(k, 0.0)
            self.s.append(max(abs(p.value), t if np.isfinite(t) else 0.0, 1e-12))
        self.start = start

    def to_p(self, x: np.ndarray) -> dict[str, float]:
        out = {}
        for k, xi, p0, lg, s in zip(self.names, x, self.p0, self.log, self.s):
            out[k] = p0 * np.exp(xi) if lg else p0 + xi * s
        return out

    def dpdx(self, vals: dict[str, float]) -> np.ndarray:
        return np.array([vals[k] if lg else s for k, lg, s in zip(self.names, self.log, self.s)])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = [], []
        for k, p0, lg, s in zip(self.names, self.p0, self.log, self.s):
            q = self.start[k]
            if lg:
                lo.append(np.log(q.lower / p0) if q.lower > 0 else -30.0)
                hi.append(np.log(q.upper / p0) if np.isfinite(q.upper) else 30.0)
            else:
                lo.append((q.lower - p0) / s if np.isfinite(q.lower) else -np.inf)
                hi.append((q.upper - p0) / s if np.isfinite(q.upper) else np.inf)
        return np.array(lo), np.array(hi)


def prepare_records(items: list[Any], *, periodic: bool = False,
                    warmup: str | float = "auto") -> list[RecordMeasurement]:
    """Records prepared as the record kind for simulation error. A ``periodic`` record is
    whole periods of a steady input, simulated to its steady state: every sample is
    judged (no warm-up, no partial unit left out)."""
    ms: list[Measurement] = prepare(items, kind="record", warmup=0 if periodic else warmup)
    recs = [m for m in ms if isinstance(m, RecordMeasurement)]
    if periodic:
        recs = [replace(m, data=m.data.renamed(m.name, np.ones(len(m.data.force), bool)))
                for m in recs]
    return recs


def fit_simulation(runs: Any, model: str | Model, *, validate: list[Any] | None = None,
                   periodic: bool = False, substeps: int = DEFAULT_SUBSTEPS,
                   warmup: str | float = "auto", seed: int = 0,
                   start: dict[str, float] | None = None,
                   bounds: dict[str, tuple[float, float]] | None = None) -> SimulationFit:
    """Identify ``model`` by simulation error on the records (module docstring)."""
    model = Model.parse(model)
    check_simulable(model)
    items = [runs] if isinstance(runs, (str, Path)) else list(runs)
    recs = prepare_records(items + list(validate or []), periodic=periodic, warmup=warmup)
    return fit_prepared(recs[:len(items)], model, validation=recs[len(items):],
                        periodic=periodic, substeps=substeps, seed=seed, start=start,
                        bounds=bounds)


def fit_prepared(fit_recs: list[RecordMeasurement], model: Model, *,
                 validation: list[RecordMeasurement] | None = None, periodic: bool = False,
                 substeps: int = DEFAULT_SUBSTEPS, seed: int = 0,
                 warm: Parameters | None = None, start: dict[str, float] | None = None,
                 bounds: dict[str, tuple[float, float]] | None = None) -> SimulationFit:
    """:func:`fit_simulation` on prepared records, each judged on its ``data.steady``
    samples (a part of a record split in time is still simulated along its whole history)."""
    check_simulable(model)
    first, origin = start_values(fit_recs, model, seed, warm, periodic=periodic,
                                 substeps=substeps, user=start, bounds=bounds)
    val_recs = list(validation or [])
    sc = _Scaled(model, first, LoopSummary.from_runs([m.data for m in fit_recs]))
    targets = [record_output(m) for m in fit_recs]
    scales = [float(np.std(y[j])) for y, j in targets]
    n_evals = [0]

    def residual(x: np.ndarray) -> np.ndarray:
        n_evals[0] += 1
        vals = sc.to_p(x)
        parts = []
        for m, (y, j), s in zip(fit_recs, targets, scales):
            try:
                pred = simulate(model, vals, m.data.force, m.fs, substeps=substeps,
                                periodic=periodic)
            except InputError:
                return np.full(sum(int(t[1].sum()) for t in targets), 1e3)
            with np.errstate(invalid="ignore", over="ignore"):
                r = (y - aligned(pred, y, j))[j] / s
            parts.append(np.where(np.isfinite(r), np.clip(r, -1e3, 1e3), 1e3))
        return np.concatenate(parts)

    lo, hi = sc.bounds()
    x0 = np.clip(np.zeros(len(sc.names)), lo + 1e-9, hi - 1e-9)
    sol = least_squares(residual, x0, bounds=(lo, hi), method="trf", x_scale=1.0,
                        diff_step=1e-6, max_nfev=MAX_NFEV_PER_PARAM * len(x0))
    vals = sc.to_p(sol.x)
    out = first.copy()
    for k, v in vals.items():
        out[k].value = float(v)
    bad = [k for k, v in vals.items() if not np.isfinite(v)]
    if bad:
        raise InputError(f"the simulation-error fit of {model.expr} diverged: "
                         f"{', '.join(bad)} not finite (start: {origin}); give --start "
                         "values or --bound limits", field="start")
    for m in fit_recs + val_recs:
        why = diverges(model, vals, m, periodic, substeps)
        if why:
            shown = ", ".join(f"{k} = {v:.4g}" for k, v in vals.items())
            raise InputError(f"the simulation-error fit of {model.expr} diverged on run "
                             f"'{m.name}': {why}, with {shown} (start: {origin}); give --start "
                             "values or --bound limits", file=m.path, field="start")
    stderr = _stderr(sc, sol, vals, scales, targets)
    preds = [predict_record(model, out, m, periodic=periodic, substeps=substeps) for m in fit_recs]
    vpreds = [predict_record(model, out, m, periodic=periodic, substeps=substeps) for m in val_recs]
    warn = band_warnings([m.data.force for m in fit_recs], [m.fs for m in fit_recs],
                         {k: float(p.value) for k, p in out.items()})
    if "FRF" in origin:
        warn.append(f"started from {origin}")
    return SimulationFit(model, out, stderr, {k: float(v.value) for k, v in first.items()},
                         preds, vpreds, periodic, int(substeps), n_evals[0], str(sol.message),
                         warn, measurement_flags([*fit_recs, *(validation or [])]))


def _stderr(sc: _Scaled, sol: Any, vals: dict[str, float], scales: list[float],
            targets: list[tuple[np.ndarray, np.ndarray]]) -> dict[str, float]:
    """Standard errors in natural units from the scaled Jacobian at the optimum (NaN
    where the covariance is singular)."""
    J = np.asarray(sol.jac, dtype=float)
    # residuals are (y - pred) / s per record: back to metres row by row
    rows = np.concatenate([np.full(int(j.sum()), s) for (y, j), s in zip(targets, scales)])
    J_m = J * rows[:, None]
    r_m = np.asarray(sol.fun) * rows
    cov, _ = covariance(J_m / sc.dpdx(vals)[None, :], float(r_m @ r_m))
    se = np.sqrt(np.abs(np.diag(cov)))
    return {k: float(s) for k, s in zip(sc.names, se)}
