"""Simulation-error fit of the modal model (:mod:`labjoint.structure.nlmode`) on records at
several levels together (issue 29 item 5).

Varied by least squares (scipy's trust-region reflective, bounded): the joint model's
parameters on mode 1, the modal force per volt ``modal.drive`` and the linear modes'
frequency and damping (``modal.f<j>``, ``modal.zeta<j>``, from the measured ones within
``LINEAR_F_RANGE`` and ``LINEAR_ZETA_RANGE``) and the shaker path's high-pass and lag
(``shaker.highpass_hz``, ``shaker.lag_s``: nlmode eqs. 4, 4b). The sensors'
participations (``modal.phi1.<s>`` and the linear modes' ``modal.g<j>.<s>``) enter the
responses linearly (nlmode eq. 3) and are solved by linear least squares at every trial
(variable projection, :mod:`.modal_project`), pooled over the fit records, with each sensor's residual term
``modal.r.<s>`` (the modes above the band, quasi-static: nlmode's eq. 3 plus r_s V^(d)) and,
when the measured modes are complex, the quadrature ones ``modal.h<j>.<s>`` (eq. 3b);
their standard errors are those of
that linear solve at the optimum (conditional on the varied parameters).

Start: from ``init`` (a fitted smaller model: the diagnosis and the ladder pass the
baseline), else k = w_1^2, c = 2 zeta_1 w_1 of the measured mode 1 and ``modal.drive``
from the linear model's projection; an added effect's parameters from a short list of
physical starts, the one that simulates the records best (at most ``MAX_STARTS``): an
elastic law 1 to 30 % of the linear force at the records' largest modal amplitude, either
sign; a slip law (coulomb, iwan, bouc_wen, richard_abbott) stuck at 5 or 20 % of k and
slipping at each level of the records' amplitude range (each record's sqrt(2) x rms of
mode 1 over its judged samples: the smallest, the largest and their geometric mean), so
a random test's micro-slip scale, far below the resonant sines', is started too; a
saturating stiffness +-5 % of k levelling off at 0.3 x the smallest and the largest
level; iwan also
in micro-slip at every record (macro-slip 10x above the largest amplitude). A trial whose
simulation diverges is rejected (its residual made large); a fit that ends diverged or
non-finite is refused naming the parameters.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from labjoint.compare.kinds.modal import ModalMeasurement
from labjoint.compare.kinds.modal_project import gain_names, project
from labjoint.compare.kinds.multistart import best_start_then_solve, modal_result
from labjoint.errors import InputError
from labjoint.models import FitResult, Model
from labjoint.structure.nlmode import QUANTITY_ORDER, check_modal_model

LINEAR_F_RANGE = (0.95, 1.05)       # the linear modes' frequency and damping, fitted within
LINEAR_ZETA_RANGE = (0.2, 5.0)      # these factors of the measured ones
HIGHPASS_RANGE = (0.0, 10.0)        # Hz: the shaker path's high-pass corner (nlmode eq. 4)
HIGHPASS_STARTS = (0.0, 1.0, 3.0)
LAG_RANGE = (0.0, 2e-3)             # s: the shaker path's first-order lag (nlmode eq. 4b)
LAG_STARTS = (0.0, 3e-4)
MAX_STARTS = 24
#: the shaker path's parameters every modal fit varies (nlmode eqs. 4, 4b)
PATH = ("shaker.highpass_hz", "shaker.lag_s")
MICRO_SLIP = 10.0                   # iwan's micro-slip-only start: phi_max this many x the largest amplitude


def record_amplitude(q: np.ndarray, m: ModalMeasurement) -> float:
    """A record's modal amplitude: sqrt(2) x the rms of q over its judged samples (a sine's
    amplitude; a random test's equivalent), its mean removed."""
    x = q[m.judged]
    x = x[np.isfinite(x)]
    return float(np.sqrt(2.0 * np.mean((x - x.mean()) ** 2))) if x.size else float("nan")


def amplitude_levels(amps: Sequence[float]) -> list[float]:
    """The records' amplitude range as slip-law start scales: the smallest and the largest
    record amplitude and, when they are more than 4x apart, their geometric mean."""
    a = [x for x in amps if np.isfinite(x) and x > 0] or [1e-3]
    lo, hi = min(a), max(a)
    return [lo] if hi <= 1.5 * lo else [lo, float(np.sqrt(lo * hi)), hi] if hi > 4 * lo else [lo, hi]


def _slip_starts(name: str, k: float, levels: Sequence[float]) -> list[dict[str, float]] | None:
    """Starts of a slip law, one set per amplitude level a (module docstring): its stuck
    stiffness 5 or 20 % of k, slipping fully at about a (coulomb: its slider at a / 2;
    iwan: macro-slip at phi_max = a, chi -0.8 (micro-slip force share nearly constant with
    amplitude) or -0.3, and at phi_max = ``MICRO_SLIP`` x the largest a, micro-slip only;
    bouc_wen: z saturating near a; richard_abbott: yield at a / 2)."""
    out = []
    # iwan also in micro-slip at every record (phi_max 10x the largest amplitude): a joint
    # that softens at micro-metres and never reaches macro-slip (BERT's free decays)
    for a in (*levels, MICRO_SLIP * max(levels)) if name == "iwan" else levels:
        for frac in (0.05, 0.2):
            kt = frac * k
            if name == "coulomb":
                out.append({"coulomb.k": kt, "coulomb.f_s": 0.5 * kt * a})
            elif name == "iwan":
                for chi in (-0.8, -0.3):
                    beta = 0.1
                    d = beta + (chi + 1) / (chi + 2)
                    out.append({"iwan.K_T": kt, "iwan.F_S": kt * a * d / (1 + beta), "iwan.chi": chi,
                                "iwan.beta": beta})
            elif name == "bouc_wen":
                out.append({"bouc_wen.k0": kt, "bouc_wen.alpha": 0.5 / a, "bouc_wen.beta": 0.5 / a,
                            "bouc_wen.n": 1.0})
            elif name == "richard_abbott":
                out.append({"richard_abbott.ke": kt, "richard_abbott.kp": 0.0,
                            "richard_abbott.F_y": 0.5 * kt * a, "richard_abbott.n": 2.0})
            else:
                return None
    return out


#: a slip law's stuck stiffness taken from linear_stiffness at its start, so the mode's
#: small-amplitude frequency stays the measured one
STUCK = {"coulomb": "coulomb.k", "iwan": "iwan.K_T", "richard_abbott": "richard_abbott.ke"}


def _starts(model: Model, known: Mapping[str, float], amp: float | Sequence[float]
            ) -> list[dict[str, float]]:
    """Physical starts of the parameters not in ``known`` (module docstring); ``amp``: the
    records' amplitudes (each record's), slip laws started at every level of their range."""
    amps = [float(amp)] if np.isscalar(amp) else [float(x) for x in amp]
    k = abs(known.get("linear_stiffness.k", 1.0))
    levels = amplitude_levels(amps)
    a = max(levels)
    sym = lambda base, *f: [s * x * base for x in f for s in (1, -1)]  # noqa: E731
    opts: dict[str, list[float]] = {
        "linear_stiffness.k": [k], "viscous.c": [known.get("viscous.c", 0.0)],
        "quadratic_stiffness.k2": sym(k / a, 0.01, 0.03, 0.1, 0.3),
        "cubic_stiffness.k3": sym(k / a**2, 0.01, 0.03, 0.1, 0.3),
        "bilinear_stiffness.dk": sym(k, 0.01, 0.03, 0.1, 0.3),
        "contact.k_c": sym(k, 0.03, 0.1, 0.3), "contact.gap": [0.1 * a, 0.5 * a],
        "saturating_stiffness.k_s": sym(k, 0.05),
        "saturating_stiffness.x_s": sorted({0.3 * min(levels), 0.3 * a}),
        "asymmetric_slip.asym": [0.3, -0.3, 0.1, -0.1],
        "offset.F0": [0.0], "shaker.highpass_hz": list(HIGHPASS_STARTS), "shaker.lag_s": list(LAG_STARTS),
    }
    new = [n for n in (*model.param_names, *PATH) if n not in known]
    # a slip law's parameters go together (one set per amplitude level), the rest by product
    slip: list[list[dict[str, float]]] = []
    for e in model.names:
        ps = [n for n in Model.parse(e).param_names if n in new]
        sl = _slip_starts(e, k, levels) if ps else None
        if sl is not None:
            slip.append([{n: v for n, v in c.items() if n in ps} for c in sl])
            new = [n for n in new if n not in ps]
    # the slip sets vary fastest: ``MAX_STARTS`` cuts other values before any amplitude level
    groups = [[{n: v} for v in opts.get(n, [0.0])] for n in new] + slip
    out = []
    for combo in itertools.product(*groups):
        d = dict(known)
        for c in combo:
            d.update(c)
        for e, kn in STUCK.items():
            if e in model.names and kn not in known and "linear_stiffness.k" in d:
                d["linear_stiffness.k"] = known.get("linear_stiffness.k", k) - d[kn]
        out.append(d)
    return out[:MAX_STARTS]


def _bounds(model: Model, bounds: Mapping[str, tuple[float, float]] | None
            ) -> dict[str, tuple[float, float]]:
    p = model.make_params()
    out = {n: (p[n].lower, p[n].upper) for n in model.param_names}
    out["modal.drive"] = (0.0, np.inf)
    for n, (lo, hi) in (bounds or {}).items():
        if n not in out:
            raise InputError(f"unknown parameter; the model has {sorted(out)}", field=f"bound.{n}")
        out[n] = (lo, hi)
    return out


def user_bounds(bnd: dict[str, tuple[float, float]], start: Mapping[str, float] | None,
                bounds: Mapping[str, tuple[float, float]] | None, known: dict[str, float],
                warm: bool) -> None:
    """The user's ``bounds`` narrow ``bnd`` (every varied parameter's) and ``start`` goes
    into ``known`` (not over a smaller fitted model's values when ``warm``); an unknown
    name, a participation (solved at every trial, never varied) or a start outside its
    bounds is refused by name. The fitter's own start is clipped into the bounds."""
    for kind, given in (("bound", bounds or {}), ("start", start or {})):
        for n in given:
            if n.startswith(("modal.phi1.", "modal.g", "modal.h", "modal.r.")) and n not in bnd:
                raise InputError("a sensor participation is solved by linear least squares at "
                                 "every trial, never varied: no start or bound", field=f"{kind}.{n}")
            if n not in bnd:
                raise InputError(f"unknown parameter; the model varies {', '.join(bnd)}",
                                 field=f"{kind}.{n}")
    for n, (lo, hi) in (bounds or {}).items():
        if not lo <= hi:
            raise InputError(f"lower bound {lo:g} above the upper {hi:g}", field=f"bound.{n}")
        bnd[n] = (float(lo), float(hi))
    for n, v in (start or {}).items():
        if not bnd[n][0] <= v <= bnd[n][1]:
            raise InputError(f"start {v:g} is outside the bounds [{bnd[n][0]:g}, {bnd[n][1]:g}]",
                             field=f"start.{n}")
        if not (warm and n in known):
            known[n] = float(v)
    for n, v in list(known.items()):
        if n in bnd and bounds and n in bounds:
            known[n] = float(np.clip(v, *bnd[n]))


def fit_modal(model: Model | str, fit_ms: Sequence[ModalMeasurement],
              val_ms: Sequence[ModalMeasurement] = (), init: Any = None,
              start: Mapping[str, float] | None = None,
              bounds: Mapping[str, tuple[float, float]] | None = None,
              max_nfev: int | None = None) -> FitResult:
    """Fit ``model`` on mode 1 of the records (module docstring)."""
    model = Model.parse(model)
    check_modal_model(model)
    if not fit_ms:
        raise InputError("no records to fit", field="runs")
    basis = fit_ms[0].basis
    start = fit_ms[0].setup.start_dict if start is None else start       # the set's own by default
    bounds = fit_ms[0].setup.bounds_dict if bounds is None else bounds
    w1 = 2 * np.pi * basis.modes[0].frequency_hz
    known: dict[str, float] = {}
    if init is not None:
        prev = init.params_.valuesdict() if hasattr(init, "params_") else dict(init)
        known = {k: v for k, v in prev.items() if k in model.param_names or k == "modal.drive"
                 or k.startswith(("modal.f", "modal.zeta", "shaker.", "mode1."))}
    path = fit_ms[0].setup.shaker         # the shaker between voltage and mode 1 (nlmode_shaker)
    loaded = {"linear_stiffness.k": w1 * w1, "viscous.c": 2 * basis.modes[0].damping_ratio * w1}
    for n in ("linear_stiffness.k", "viscous.c"):
        if n in model.param_names:
            known.setdefault(n, loaded[n])
    bnd = _bounds(model, None)
    drive_name = "modal.drive"
    if path is not None:
        del bnd["modal.drive"]
        bnd.update(path.bounds())
        drive_name = path.free
    lin_names = [f"modal.{p}{j + 2}" for j in range(len(basis.linear)) for p in ("f", "zeta")]
    for j, mode in enumerate(basis.linear):
        f0, z0 = mode.frequency_hz, mode.damping_ratio
        bnd[f"modal.f{j + 2}"] = (LINEAR_F_RANGE[0] * f0, LINEAR_F_RANGE[1] * f0)
        bnd[f"modal.zeta{j + 2}"] = (LINEAR_ZETA_RANGE[0] * z0, LINEAR_ZETA_RANGE[1] * z0)
    bnd["shaker.highpass_hz"] = HIGHPASS_RANGE
    bnd["shaker.lag_s"] = LAG_RANGE
    user_bounds(bnd, start, bounds, known, init is not None)
    if drive_name is not None and drive_name not in known:
        q1 = [m.plain_states(model, {**{n: loaded.get(n, known.get(n, 0.0)) if path else known.get(n, 0.0)
                                         for n in model.param_names}, "modal.drive": 1.0})
              for m in fit_ms]
        if not all(np.all(np.isfinite(q)) for q in q1):
            raise InputError("the linear start diverges: the mode needs a positive stiffness and "
                             "damping (check the modes file)", field="modal")
        # the reference's own participation is 1: its mode-1 term scales with modal.drive
        A = np.concatenate([((q[m.judged, QUANTITY_ORDER[m.quantities[0]]]
                              - q[m.judged, QUANTITY_ORDER[m.quantities[0]]].mean()) / m.scales[0])
                            for m, q in zip(fit_ms, q1)])
        y = np.concatenate([m.data.force[:m.judged.stop - m.judged.start] for m in fit_ms])
        known["modal.drive"] = max(float(A @ y / (A @ A)), 1e-12)
        if path is not None:      # the free shaker parameter from that drive
            known.update(path.free_start(known.pop("modal.drive")))
    if path is not None and init is None:     # the structure's own k, c: the mode less the shaker's share
        own = path.structure_start(w1, basis.modes[0].damping_ratio, known)
        for n, v in own.items():
            if n in model.param_names and known.get(n) == loaded[n] and n not in (start or {}):
                known[n] = v
    for j, mode in enumerate(basis.linear):
        known.setdefault(f"modal.f{j + 2}", mode.frequency_hz)
        known.setdefault(f"modal.zeta{j + 2}", mode.damping_ratio)
    every = [*model.param_names, *([drive_name] if drive_name else []), *lin_names, *PATH]
    fixed = {n: bnd[n][0] for n in every if bnd[n][0] == bnd[n][1]}     # --bound n=v:v holds n
    names = [n for n in every if n not in fixed]

    def residual_of(vals: Mapping[str, float]) -> np.ndarray | None:
        try:
            qs = [m.states(model, vals) for m in fit_ms]
        except InputError:
            return None
        if not all(np.all(np.isfinite(q)) for q in qs):
            return None
        return project(fit_ms, qs, vals)[2]

    sub = [e for e in model.names if all(p in known for p in Model.parse(e).param_names)]
    amp: list[float] = [1e-3]
    if sub:     # each record's modal amplitude under the effects already known
        q0 = [m.states(Model.parse("+".join(sub)), known) for m in fit_ms]
        amp = [record_amplitude(q[:, 0], m) for q, m in zip(q0, fit_ms)]
    starts = [np.array([np.clip(cand[n], *bnd[n]) for n in names]) for cand in _starts(model, known, amp)]
    x, sol, scale = best_start_then_solve(lambda z: residual_of({**fixed, **dict(zip(names, z))}),
                                          names, bnd, starts, max_nfev,
                                          f"every start of {model.expr} diverges on the records")
    vals = {**fixed, **dict(zip(names, x))}
    qs = [m.states(model, vals) for m in fit_ms]
    if not all(np.all(np.isfinite(q)) for q in qs):
        raise InputError(f"the fitted model diverges on the records ({vals})", field="model")
    gains, gse, r = project(fit_ms, qs, vals)
    J = sol.jac / scale[None, :] if sol.jac.shape[0] == r.size else None
    dof = max(1, r.size - len(names) - len(gains))
    stderr: dict[str, float] = {}
    corr = np.eye(len(names))
    if J is not None:
        try:
            cov = np.linalg.inv(J.T @ J) * float(r @ r) / dof
            d = np.sqrt(np.clip(np.diag(cov), 0, None))
            stderr = {n: float(e) for n, e in zip(names, d)}
            corr = cov / np.outer(np.where(d > 0, d, 1), np.where(d > 0, d, 1))
        except np.linalg.LinAlgError:
            stderr = {n: float("nan") for n in names}
    stderr.update(gse)
    params = model.make_params(values={n: vals[n] for n in model.param_names})
    if path is None:
        params.add("modal.drive", vals["modal.drive"], lower=0.0, unit="m/s^2 per V")
    elif drive_name:
        params.add(drive_name, vals[drive_name], lower=0.0, unit=path.free_unit)
    params.add("shaker.highpass_hz", vals["shaker.highpass_hz"], lower=bnd["shaker.highpass_hz"][0],
               upper=bnd["shaker.highpass_hz"][1],
               unit="Hz")
    params.add("shaker.lag_s", vals["shaker.lag_s"], lower=bnd["shaker.lag_s"][0], upper=bnd["shaker.lag_s"][1],
               unit="s")
    for k in lin_names:
        params.add(k, vals[k], lower=bnd[k][0], upper=bnd[k][1], unit="Hz" if ".f" in k else "1")
    for k, v in gains.items():
        params.add(k, v, unit="1" if k.startswith(("modal.phi1.", "modal.h1.")) else
                   "m/V (residual flexibility)" if k.startswith("modal.r.") else "per V")
    for k, e in stderr.items():
        params[k].stderr = e
    for k in gain_names(fit_ms[0]):
        if k not in params:
            params.add(k, 0.0)
    return modal_result(model, params, names, stderr, corr, sol, r, fit_ms, val_ms)

