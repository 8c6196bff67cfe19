"""Simulation-error fit of the modal model with the joint between two measured points
(:mod:`labjoint.structure.nlmode_pair`, issue 29 item 5) on records at several levels.

Varied by least squares (scipy's trust-region reflective, bounded): the joint law's
parameters (the force the joint adds to the measured modes, per unit modal mass of mode 1),
every mode's drive per volt ``modal.drive<j>``, the relative modal masses ``modal.mass<j>``
(j >= 2) and the shaker path's high-pass ``shaker.highpass_hz`` and lag ``shaker.lag_s``; with
``setup.joint_shape`` the joint's participation in modes 2..N too (``modal.joint<j>``: a joint
no sensor pair sees as it moves). The sensors read the modes through their measured shapes
(nothing per channel is fitted).

Start: the drives from the linear model (no joint force: each mode's unit-gain response
read through the measured shapes, one linear least squares over the records), masses 1,
the law's linear terms 0 (the measured modes already hold the joint at rest); an added
effect's parameters from the single-mode fit's physical starts
(:func:`labjoint.compare.kinds.modal_fit._starts`) on the scale k = w_1^2 / D_1^2 (the
stiffness that would double mode 1's) at the largest relative displacement the linear
model gives; from ``init`` (a smaller fitted model) its values. A fitted participation D_j
starts at the sensors' difference and at 3, 10 and 30 times max(|D_j|, |D_1|) (its sign),
the mass mu_j with it so that D_j / mu_j stays the sensors' (the feedback on mode j), the
start of least residual kept. A trial whose simulation
diverges is rejected; a fit that ends diverged is refused naming the parameters.

Through the shaker (a voltage drive with ``setup.shaker``): the drives are no longer free;
every mode's is the shaker's force at the drive point (:mod:`labjoint.structure.nlmode_shaker`
P1), and the one shaker parameter the records determine (``path.free``: one of Bl, R and
``mode1.mass_kg``, the single mode's identifiability rules) is varied in their place,
started from mode 1's linear drive; the relative masses from the linear drives' ratios.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from labjoint.compare.kinds.modal import ModalMeasurement
from labjoint.compare.kinds.modal_fit import HIGHPASS_RANGE, LAG_RANGE, PATH, STUCK, _bounds, _starts
from labjoint.compare.kinds.multistart import best_start_then_solve, modal_result
from labjoint.errors import InputError
from labjoint.models import FitResult, Model
from labjoint.structure.nlmode import QUANTITY_ORDER, check_modal_model, linear_states
from labjoint.structure.nlmode_pair import differences, mode_reading

MASS_RANGE = (1e-3, 1e3)
LINEAR_TERMS = ("linear_stiffness.k", "viscous.c")


def _linear_drives(fit_ms: Sequence[ModalMeasurement], d: np.ndarray
                   ) -> tuple[dict[str, float], Callable[[np.ndarray], float]]:
    """Every mode's drive per volt from the linear model, and the largest |u| it gives as a
    function of the joint's participations D."""
    basis = fit_ms[0].basis
    cols, ys, us = [], [], []
    for m in fit_ms:
        p = [linear_states(mode, m.drive) for mode in basis.modes]          # unit gain
        j = m.judged
        blocks = []
        for ch, qty, sc in zip(m.channels, m.quantities, m.scales):
            o = QUANTITY_ORDER[qty]
            reads = [mode_reading(x, mode, ch, o, m.drive.fs)[j] for mode, x in zip(basis.modes, p)]
            blocks.append(np.column_stack([(r - r.mean()) / sc for r in reads]))
        cols.append(np.vstack(blocks))
        ys.append(m.data.force)
        us.append(np.column_stack([x[j, 0] for x in p]))
    A, y = np.vstack(cols), np.concatenate(ys)
    if not np.all(np.isfinite(A)):
        raise InputError("the linear modes diverge (check the modes file)", field="modal")
    g = np.linalg.lstsq(A, y, rcond=None)[0]
    def amp(dj: np.ndarray) -> float:
        return max(float(np.max(np.abs(u @ (g * dj)))) for u in us)

    return {f"modal.drive{i + 1}": float(v) for i, v in enumerate(g)}, amp


def _joint_starts(joints: Sequence[str], d: np.ndarray, known: Mapping[str, float],
                  preset: set[str]) -> list[dict[str, float]]:
    """Starts of the fitted participations D_j (module docstring); one empty start without
    them. A value already known (``init``, ``--start``) is the only start of its D_j; a mass
    in ``preset`` (``init``, ``--start``) is kept."""
    if not joints:
        return [{}]
    out = []
    for factor in (None, 3.0, 10.0, 30.0):
        s: dict[str, float] = {}
        for n in joints:
            j = int(n.removeprefix("modal.joint"))
            meas = float(d[j - 1])
            if n in known:
                s[n] = known[n]
                continue
            v = meas if factor is None else float(np.copysign(factor * max(abs(meas), abs(d[0])), meas or 1.0))
            s[n] = v
            mass = f"modal.mass{j}"
            if factor is not None and mass not in preset and meas:
                s[mass] = float(np.clip(known.get(mass, 1.0) * abs(v / meas), *MASS_RANGE))
        if s not in out:
            out.append(s)
    return out


def fit_modal_pair(model: Model | str, fit_ms: Sequence[ModalMeasurement],
                   val_ms: Sequence[ModalMeasurement] = (), init: Any = None,
                   start: Mapping[str, float] | None = None,
                   bounds: Mapping[str, tuple[float, float]] | None = None,
                   max_nfev: int | None = None) -> FitResult:
    """Fit ``model`` as the joint between the records' two sensors (module docstring)."""
    model = Model.parse(model)
    check_modal_model(model)
    if "inertia" in model.names:
        raise InputError("inertia cannot act between two points of the modal model", field="model")
    basis, between = fit_ms[0].basis, fit_ms[0].between
    nm = len(basis.modes)
    d = differences(basis, *between)
    drives = [f"modal.drive{j}" for j in range(1, nm + 1)]
    masses = [f"modal.mass{j}" for j in range(2, nm + 1)]
    joints = [f"modal.joint{j}" for j in range(2, nm + 1)] if fit_ms[0].setup.joint_shape else []
    known: dict[str, float] = {}
    if init is not None:
        prev = init.params_.valuesdict() if hasattr(init, "params_") else dict(init)
        known = {k: float(v) for k, v in prev.items() if k in model.param_names
                 or k.startswith(("modal.drive", "modal.mass", "modal.joint", "shaker.", "mode1."))}
    for n in LINEAR_TERMS:
        if n in model.param_names:
            known.setdefault(n, 0.0)
    path = fit_ms[0].setup.shaker                 # the shaker at its drive point, on every mode
    if path is not None:
        path.participations(basis)
        drives = [path.free] if path.free else []
    bnd = _bounds(model, bounds and {k: v for k, v in bounds.items() if k in model.param_names})
    bnd.pop("modal.drive", None)
    for n in drives:
        bnd[n] = (-np.inf, np.inf) if path is None else (0.0, np.inf)
    for n in masses:
        bnd[n] = MASS_RANGE
    for n in joints:
        bnd[n] = (-np.inf, np.inf)
    bnd["shaker.highpass_hz"] = HIGHPASS_RANGE
    bnd["shaker.lag_s"] = LAG_RANGE
    for n, (lo, hi) in (bounds or {}).items():
        if n not in bnd:
            raise InputError(f"unknown parameter; the model has {sorted(bnd)}", field=f"bound.{n}")
        bnd[n] = (lo, hi)
    for n, v in (start or {}).items():
        if n not in bnd:
            raise InputError(f"unknown parameter; the model has {sorted(bnd)}", field=f"start.{n}")
        if not bnd[n][0] <= v <= bnd[n][1]:
            raise InputError(f"start {v:g} is outside the bounds {bnd[n]}", field=f"start.{n}")
        if init is None or n not in known:       # a smaller fitted model's values stay
            known[n] = float(v)
    g, amp = _linear_drives(fit_ms, d)
    if path is None:
        for n, v in g.items():
            known.setdefault(n, v)
    else:           # the free shaker parameter from mode 1's drive, the masses from the ratios
        for n, v in path.pair_free_start(g["modal.drive1"]).items():
            known.setdefault(n, v)
        phi = path.participations(basis)
        for j, n in enumerate(masses, start=1):
            mu = phi[j] / phi[0] * g["modal.drive1"] / g[f"modal.drive{j + 1}"] if g[f"modal.drive{j + 1}"] else 0.0
            known.setdefault(n, float(np.clip(mu, *MASS_RANGE)) if np.isfinite(mu) and mu > 0 else 1.0)
    preset = set(known)
    for n in masses:
        known.setdefault(n, 1.0)
    w1 = 2 * np.pi * basis.modes[0].frequency_hz
    k_ref = w1 * w1 / max(d[0] ** 2, float(np.max(d ** 2)) * 1e-3)
    every = [*model.param_names, *drives, *masses, *joints, *PATH]
    fixed = {n: bnd[n][0] for n in every if bnd[n][0] == bnd[n][1]}     # a bound n=v:v holds n
    names = [n for n in every if n not in fixed]

    def residual_of(vals: Mapping[str, float]) -> np.ndarray | None:
        out = []
        for m in fit_ms:
            try:
                q = m.states(model, vals)
            except InputError:
                return None
            if not np.all(np.isfinite(q)):
                return None
            out.append(m.normalized(m.responses(model, vals, q)) - m.data.force)
        return np.concatenate(out)

    best = None
    for shape in _joint_starts(joints, d, known, preset):
        # each participation's own solve (the law's starts on the relative displacement it
        # gives), the least final cost kept: one solve without fitted participations
        dj = d.copy()
        for n, v in shape.items():
            if n.startswith("modal.joint"):
                dj[int(n.removeprefix("modal.joint")) - 1] = v
        starts = []
        for cand in _starts(model, {**known, "linear_stiffness.k": k_ref}, amp(dj)):
            if "linear_stiffness.k" in known:   # less a new slip law's stuck stiffness
                cand["linear_stiffness.k"] = known["linear_stiffness.k"] - sum(
                    cand[kn] for e, kn in STUCK.items() if e in model.names and kn not in known)
            c = {**cand, **shape}
            starts.append(np.array([np.clip(c.get(n, 0.0), *bnd[n]) for n in names]))
        try:
            got = best_start_then_solve(
                lambda z: residual_of({**fixed, **dict(zip(names, z))}), names, bnd, starts, max_nfev,
                f"every start of {model.expr} between {between[0]} and {between[1]} diverges on the records")
        except InputError:
            if len(joints) == 0:
                raise
            continue
        if best is None or got[1].cost < best[1].cost:
            best = got
    if best is None:
        raise InputError(f"every start of {model.expr} between {between[0]} and {between[1]} "
                         "diverges on the records", field="model")
    x, sol, scale = best
    lo = np.array([bnd[n][0] for n in names])
    hi = np.array([bnd[n][1] for n in names])
    vals = {**fixed, **dict(zip(names, x))}
    r = residual_of(vals)
    if r is None:
        raise InputError(f"the fitted model diverges on the records ({vals})", field="model")
    stderr: dict[str, float] = {n: float("nan") for n in names}
    corr = np.eye(len(names))
    if sol.jac.shape[0] == r.size:
        # standard errors of the parameters inside their bounds whose change the records
        # see (a parameter at a bound, e.g. no high-pass, has none: NaN, flagged)
        J = sol.jac / scale[None, :]
        free = np.array([np.linalg.norm(J[:, i]) > 0 and not (np.isclose(x[i], lo[i], rtol=1e-9, atol=1e-15)
                                                              or np.isclose(x[i], hi[i], rtol=1e-9, atol=0))
                         for i in range(len(names))])
        Jf = J[:, free]
        try:
            cov = np.linalg.inv(Jf.T @ Jf) * float(r @ r) / max(1, r.size - int(free.sum()))
            e = np.sqrt(np.clip(np.diag(cov), 0, None))
            idx = np.flatnonzero(free)
            for i, v in zip(idx, e):
                stderr[names[i]] = float(v)
            corr[np.ix_(idx, idx)] = cov / np.outer(np.where(e > 0, e, 1), np.where(e > 0, e, 1))
        except np.linalg.LinAlgError:
            pass
    params = model.make_params(values={n: vals[n] for n in model.param_names})
    for n in drives:
        if path is None:
            params.add(n, vals[n], unit="m/s^2 per V")
        else:
            params.add(n, vals[n], lower=0.0, unit=path.free_unit)
    for n in masses:
        params.add(n, vals[n], lower=MASS_RANGE[0], upper=MASS_RANGE[1], unit="1")
    for n in joints:
        params.add(n, vals[n], unit="1")
    params.add("shaker.highpass_hz", vals["shaker.highpass_hz"], lower=0.0, upper=HIGHPASS_RANGE[1], unit="Hz")
    params.add("shaker.lag_s", vals["shaker.lag_s"], lower=0.0, upper=LAG_RANGE[1], unit="s")
    for k, e in stderr.items():
        params[k].stderr = e
    return modal_result(model, params, names, stderr, corr, sol, r, fit_ms, val_ms)
