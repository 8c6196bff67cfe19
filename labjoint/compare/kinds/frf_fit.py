"""Fitting a joint model inside a structure on FRF measurements (the ``frf`` kind's fitter).

The search is :func:`labjoint.structure.stage2.fit_law` on the whitened residuals of the
fit measurements (:mod:`labjoint.compare.kinds.frf`): weighted least squares, each
phasor weighted by its measurement std, so the standard errors are those of the
linearised estimate under the stated noise. Starts (no loop to guess from): a parameter
the structure's own joint law has keeps its value (the structure file's law is the
user's prior); ``init`` (a previous fit) overrides; an added effect starts from the
joint's stuck stiffness k_j and the slip amplitude u_j the baseline predicts at the
highest level (:func:`physical_start`): stiffnesses at ``ADDED_STIFFNESS`` of k_j (beside
what the model already has), slip strengths at stiffness x u_j (so the effect slips
within the measured range), a viscous term at 1 % critical of the joint on mode 1,
shape parameters at mid values, linear-in-parameter terms (cubic, quadratic, offset, mass)
at the value that adds that share at u_j, each sign tried (:func:`sign_starts`: the
search starts from the better one; a term started at zero had no slope to follow). Scale
parameters stay within ``SCALE_RANGE`` of their start, signed ones are searched in units
of their start's magnitude. A trial point
where harmonic balance does not converge (e.g. a joint in full macro-slip) answers
``NO_SOLUTION`` x the last residual, so the search steps back instead of failing.

The fit measurements may include other kinds judged on the same structure's joint law
(backbones, :mod:`labjoint.compare.kinds.backbone`): each gives its whitened prediction
for a law (``predict_law``), their residuals are stacked with the FRF ones into one
weighted least-squares problem, the starts still come from the FRF sweeps, and the
Jacobian is then taken by differences (the analytic one is harmonic balance's, per step).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from labjoint.compare.kinds.frf import FrfMeasurement, whiten
from labjoint.errors import InputError
from labjoint.models import FitResult, Model
from labjoint.models.scores import nrmse_from_sums, pooled_nrmse
from labjoint.structure.hbm import ConvergenceError
from labjoint.structure.joint import refusal
from labjoint.structure.stage2 import fit_law
from labjoint.vocabulary import EFFECTS

ADDED_STIFFNESS = 0.2
STIFFNESSES = ("K_T", "k", "ke", "k0")
NO_SOLUTION = 3.0
SCALE_RANGE = 1e3
SHAPES = {"iwan.chi": -0.5, "iwan.beta": 0.1, "richard_abbott.n": 2.0, "asymmetric_slip.asym": 0.3,
          "bouc_wen.n": 1.0, "valanis.kappa": 0.5}
#: effects that can stand in a joint law inside a structure's harmonic balance: every
#: vocabulary effect the joint does not refuse (:func:`labjoint.structure.joint.refusal`)
FRF_EFFECTS = tuple(n for n in EFFECTS if refusal(n) is None)


def slip_amplitude(ms: Sequence[FrfMeasurement], model: Model, params: Mapping[str, float]) -> float:
    """Largest tangential slip amplitude (m) of a joint patch over the measurements, as the
    model predicts it (harmonic 1 of the joint rotation times the joint radius)."""
    top = max(ms, key=lambda m: m.level_n)
    pr = top.predictor
    law = pr.law_of(model, {k: params[k] for k in model.param_names})
    sysm = pr.system_with(law)
    rot = pr.predict_rows(top.frfset, law, sysm.selectors)
    r = max(e.joint.radius_m for e in sysm.elements)
    return float(r * np.max(np.abs(rot))) if rot.size else 0.0


def physical_start(model: Model, known: Mapping[str, float], k_joint: float, u_slip: float,
                   f1_hz: float, stiffer: float = 1.0) -> dict[str, float]:
    """Start values of ``model``'s parameters not in ``known`` (module docstring), chosen by
    the parameter's unit so that every added term carries ``ADDED_STIFFNESS`` of the
    joint's stuck stiffness k_j at the slip amplitude u_j the baseline predicts: a
    stiffness ka = 0.2 k_j, a force ka u_j, a cubic ka / u_j^2, a quadratic ka / u_j, a
    gap u_j / 2, a mass ka / w_1^2; shapes at mid values. Signed terms start positive;
    :func:`sign_starts` gives their mirror images.

    >>> s = physical_start(Model.parse("cubic_stiffness+offset"), {}, 1e8, 1e-5, 30.0)
    >>> round(s["cubic_stiffness.k3"] / 2e17, 6), round(s["offset.F0"], 6)
    (1.0, 200.0)
    """
    out = dict(known)
    u = max(u_slip, 1e-12)
    ka = ADDED_STIFFNESS * k_joint
    w1 = 2 * np.pi * f1_hz
    units = {k: q.unit for k, q in model.make_params().items()}
    for name in model.param_names:
        if name in out:
            continue
        eff, p = name.split(".")
        unit = units[name]
        if name in SHAPES:
            out[name] = SHAPES[name]
        elif eff == "linear_stiffness":
            out[name] = k_joint
        elif p == "kp":
            out[name] = 0.05 * ka
        elif unit == "N/m":
            out[name] = ka
        elif unit == "N":
            out[name] = ka * u
        elif unit == "m":                  # a gap: stiffer when smaller
            out[name] = 0.5 * u / stiffer ** 2
        elif unit in BY_UNIT:
            out[name] = BY_UNIT[unit](ka, u, w1)
        elif eff == "viscous":
            out[name] = 2 * 0.01 * k_joint / w1
        else:
            out[name] = 0.0
    return out


#: start of a parameter by its unit (ka: added stiffness, u: slip amplitude, w1: mode 1)
BY_UNIT = {"N/m^3": lambda ka, u, w1: ka / u ** 2, "N/m^2": lambda ka, u, w1: ka / u,
           "kg": lambda ka, u, w1: ka / w1 ** 2,
           "1/m": lambda ka, u, w1: 1.0 / u, "N^(1-n)/m": lambda ka, u, w1: 0.5 / u}
#: units of terms whose sign the data must choose (the objective has a minimum for each)
SIGNED_UNITS = ("N/m^3", "N/m^2", "N", "kg")
MAX_STARTS = 4
#: the search's Jacobian from the harmonic balance's own (implicit function theorem,
#: :meth:`FrfPredictor.predict_jacobian`); False: finite differences (benchmarks compare)
ANALYTIC_JACOBIAN = True
#: slip amplitudes (x the baseline's) tried in turn when no start can be solved
SLIP_SCALES = (1.0, 4.0, 16.0)


def sign_starts(model: Model, start: Mapping[str, float], added: Sequence[str]) -> list[dict[str, float]]:
    """The start and its mirror images in the signs of the added signed terms (at most
    ``MAX_STARTS``): hardening and softening, a preload up or down.

    >>> [s["cubic_stiffness.k3"] for s in sign_starts(Model.parse("cubic_stiffness"), {"cubic_stiffness.k3": 2.0}, ["cubic_stiffness.k3"])]
    [2.0, -2.0]
    """
    q = model.make_params()
    signed = [n for n in added if q[n].lower < 0 and start.get(n, 0.0) != 0.0
              and (q[n].unit in SIGNED_UNITS or n == "asymmetric_slip.asym")
              and not n.startswith("linear_stiffness.")]
    out = [dict(start)]
    for n in signed:
        out += [{**s, n: -s[n]} for s in out]
    return out[:MAX_STARTS]


def start_values(model: Model, ms: Sequence[FrfMeasurement],
                 init: FitResult | Mapping[str, float] | None, slip_scale: float = 1.0) -> dict[str, float]:
    """The start of every parameter (module docstring)."""
    return _starts(model, ms, init, slip_scale)[0]


def _starts(model: Model, ms: Sequence[FrfMeasurement], init: FitResult | Mapping[str, float] | None,
            slip_scale: float = 1.0) -> tuple[dict[str, float], list[str]]:
    pr = ms[0].predictor
    own = {k: v for k, v in pr.law.params.items() if k in model.param_names}
    prev = init.params_.valuesdict() if isinstance(init, FitResult) else dict(init or {})
    known = {**own, **{k: float(v) for k, v in prev.items() if k in model.param_names}}
    missing = [n for n in model.param_names if n not in known]
    if not missing:
        return known, []
    k_joint = pr.law.initial_stiffness()
    have = [n for n in model.names if all(f"{n}.{q.name}" in known for q in EFFECTS[n].params)]
    try:                                   # the effects already known, if they make a model
        base = Model.parse("+".join(have) or "linear_stiffness")
    except InputError:
        base = Model.parse("linear_stiffness")
    base_vals = physical_start(base, known, k_joint, 0.0, 1.0)
    u = slip_scale * slip_amplitude(ms, base, base_vals)
    out = physical_start(model, known, k_joint, u, float(pr.natural_frequencies(1)[0]), slip_scale)
    return split_stiffness(out, missing), missing


def best_start(model: Model, ms: Sequence[FrfMeasurement], init: Any) -> dict[str, float]:
    """The start the data prefer among the signed mirror images (:func:`sign_starts`); if
    harmonic balance cannot follow the sweeps from any of them (an added term that slips
    or softens too much), the same with the slip amplitude x4, x16 (stiffer: slipping
    later, a gap 16 and 256 times smaller)."""
    pr = ms[0].predictor
    for scale in SLIP_SCALES:
        start, added = _starts(model, ms, init, scale)
        starts = sign_starts(model, start, added)
        costs = []
        for st in starts:
            try:
                r = np.concatenate([whitened_residual(m, pr.law_of(model, st)) for m in ms])
                costs.append(float(r @ r) if np.all(np.isfinite(r)) else np.inf)
            except (ConvergenceError, np.linalg.LinAlgError):
                costs.append(np.inf)
        if np.isfinite(min(costs)):
            return starts[int(np.argmin(costs))]
        if not added:
            break
    raise ConvergenceError(f"harmonic balance cannot follow the measured sweeps from any start of "
                           f"'{model.expr}'")


def neutral_start(model: Model, ms: Sequence[FrfMeasurement], init: Any) -> dict[str, float]:
    """The start with every added term (nearly) vanishing beside the known ones (not split):
    signed terms and gaps at zero, added stiffnesses at 1e-6 of theirs."""
    start, added = _starts(model, ms, init)
    pr = ms[0].predictor
    prev = init.params_.valuesdict() if isinstance(init, FitResult) else dict(init or {})
    known = {**{k: v for k, v in pr.law.params.items() if k in model.param_names},
             **{k: float(v) for k, v in prev.items() if k in model.param_names}}
    start.update(known)
    q = model.make_params()
    for n in added:
        if q[n].lower < 0 or q[n].unit == "m":
            start[n] = 0.0
        elif q[n].unit == "N/m":
            start[n] *= 1e-6
    return start


def split_stiffness(start: dict[str, float], added: Sequence[str]) -> dict[str, float]:
    """An added effect's stiffness is taken from a known linear stiffness rather than put
    beside it, so that the stuck joint (and the baseline's resonance) stays where the
    data put it; with a sharp resonance a start shifted by a few bandwidths leaves the
    least-squares search no slope to follow.

    >>> split_stiffness({"linear_stiffness.k": 1e8, "iwan.K_T": 2e7, "iwan.F_S": 5.0}, ["iwan.K_T", "iwan.F_S"])
    {'linear_stiffness.k': 80000000.0, 'iwan.K_T': 20000000.0, 'iwan.F_S': 5.0}
    """
    k = start.get("linear_stiffness.k")
    if k is None or "linear_stiffness.k" in added:
        return start
    extra = sum(start[n] for n in added if n.split(".")[1] in STIFFNESSES and not n.startswith("linear_stiffness."))
    if extra > 0:
        start = {**start, "linear_stiffness.k": max(k - extra, (1 - ADDED_STIFFNESS) * k)}
    return start


def fit_frf(model: Model | str, fit_ms: Sequence[FrfMeasurement],
            val_ms: Sequence[FrfMeasurement] = (), init: Any = None,
            max_nfev: int | None = None) -> FitResult:
    """Fit ``model`` (every joint's law) on the fit measurements (module docstring)."""
    model = Model.parse(model)
    bad = [n for n in model.names if refusal(n)]
    if bad:
        raise InputError(f"effect '{bad[0]}' cannot act in a structure's joint: {refusal(bad[0])}",
                         field="model")
    frf_ms = [m for m in fit_ms if m.kind == "frf"]
    if not frf_ms:
        raise InputError("no FRF measurements to fit", field="runs")
    pr = frf_ms[0].predictor
    names = model.param_names
    last: list[np.ndarray] = []
    try:
        start = best_start(model, frf_ms, init)
    except ConvergenceError:      # judged at its neutral values, flagged: not a crash of the diagnosis
        start, max_nfev = neutral_start(model, frf_ms, init), 1
    law0 = pr.law_of(model, start)
    typical = {n: abs(v) for n, v in start.items() if v}

    def residual(law) -> np.ndarray:
        try:
            r = np.concatenate([whitened_residual(m, law) for m in fit_ms])
        except (ConvergenceError, ValueError, np.linalg.LinAlgError):
            if not last:
                raise
            return NO_SOLUTION * last[0]      # a trial the solver cannot follow: rejected
        last[:] = [r]
        return r

    def jacobian(law) -> np.ndarray:
        cols = []
        for m in fit_ms:
            _, d = m.predictor.predict_jacobian(m.frfset, law, names, m.frfset.harmonics)
            cols.append(np.column_stack([whiten(d[..., j], m.std) for j in range(len(names))]))
        return np.vstack(cols)

    lf = fit_law(law0, names, residual, None, max_nfev=max_nfev or 12 * len(names),
                 scale_range=SCALE_RANGE, typical=typical,
                 jacobian=jacobian if ANALYTIC_JACOBIAN and len(frf_ms) == len(fit_ms) else None)
    params = model.make_params(values=lf.values)
    for k in names:
        params[k].stderr = lf.stderr[k]
    sse = {m.name: _sse(m, lf.law) for m in (*fit_ms, *val_ms)}
    ssf = {m.name: float(m.data.force @ m.data.force) for m in (*fit_ms, *val_ms)}
    fn, vn = [m.name for m in fit_ms], [m.name for m in val_ms]
    return FitResult(model, params, tuple(names), dict(lf.stderr), lf.correlation,
                     pooled_nrmse([sse[n] for n in fn], [ssf[n] for n in fn]),
                     {n: nrmse_from_sums(sse[n], ssf[n]) for n in fn},
                     pooled_nrmse([sse[n] for n in vn], [ssf[n] for n in vn]) if vn else None,
                     {n: nrmse_from_sums(sse[n], ssf[n]) for n in vn}, lf.n_evals, lf.converged,
                     "; ".join([lf.message, *lf.flags]), int(sum(m.data.force.size for m in fit_ms)), 2 * lf.cost,
                     (), tuple(fn), tuple(vn))


def whitened_residual(m: FrfMeasurement, law) -> np.ndarray:
    """Model minus measured, whitened, of any measurement with ``predict_law``."""
    return m.predict_law(law) - m.data.force


def _sse(m: FrfMeasurement, law) -> float:
    r = whitened_residual(m, law)
    return float(r @ r)
