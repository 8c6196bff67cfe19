"""A joint between two measured points of a structure nobody can describe (issue 29 item 5):
the modal model of :mod:`labjoint.structure.nlmode` with the joint acting on the relative
displacement of two sensors instead of on one mode's coordinate.

The structure is its measured linear modes j = 1..N (f_j, zeta_j, and the shape phi_sj at
each sensor s, relative to the reference sensor, from ``labjoint modes``). Mode j's
coordinate eta_j is the displacement it gives the reference sensor, so y_s = sum_j phi_sj
eta_j. A joint between sensors a and b carries the force F of any effect expression the
forward simulator integrates (:data:`labjoint.structure.nlmode.MODAL_EFFECTS`) on their
relative displacement and velocity

    u = y_a - y_b = sum_j D_j eta_j,   D_j = phi_aj - phi_bj                       (5)

and pushes a and b apart by it, which in mode j's equation is its projection D_j:

    eta_j'' + 2 zeta_j w_j eta_j' + w_j^2 eta_j + (D_j / mu_j) F(u, u', z) = g_j V(t)  (6)

The joint's participation D_j may also be fitted instead (``modal.joint<j>``, j >= 2, the
joint's relative displacement per unit eta_j; D_1 stays the sensors' difference, which
fixes the law's units): a joint that lies between two points no sensor sees, e.g. a lap
whose slip follows the beam's slope or curvature there rather than the sensors'
displacements, so that a higher mode moves it far more than its shape at the sensors says.
F is per unit modal mass of mode 1 (as the single-mode kind's law is), mu_j the modal mass
of mode j relative to mode 1 (``modal.mass<j>``, j >= 2, default 1; a relative shape does
not fix it, so it is a parameter), g_j the modal drive per volt (``modal.drive<j>``). The
measured modes are the structure with the joint at rest: F holds only what the joint
adds to them (an even or cubic stiffness, slip), so a ``linear_stiffness`` in F shifts
the measured modes. The hysteretic states z (Bouc-Wen, the Jenkins slider) and a Masing
law's reversal stack (iwan, richard_abbott; carried per RK4 step) follow u.

Sensors read their quantity's order d = 0, 1, 2 of the modes through the measured shapes

    y_s^(d) = sum_j phi_sj eta_j^(d)                                               (7)

(eq. 3 of :mod:`labjoint.structure.nlmode`), from the integrated states. A shape measured
complex, phi_sj = a + i b, reads its imaginary part on the mode's quadrature

    y_s^(d) = sum_j [a_sj eta_j^(d) + b_sj eta_j^(d+1) / w_j]                      (7b)

(i times a response is its derivative over w near the mode, where the mode's part lies;
nlmode eq. 3b with the measured b in place of a fitted h). The joint's D_j stays the real
parts' difference: its force acts on the modes as the real shapes say (stated).

Integrator (stated):
classical RK4 on (eta, eta', z) with the drive's substeps (w h <= 0.1 at 1.5x the highest
mode), the joint force from the forward simulator's own rates
(:func:`labjoint.models.simulate._rates` on u, u': one source of the laws), the voltage
between samples band-limited, through the shaker path's high-pass when the drive has one.
A record starts from rest, a steady sine from every mode's linear steady state.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numba import njit

from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.models.effects._masing import masing_commit, masing_eval, masing_state
from labjoint.models.simulate import _coefficients, _rates, masing_coefficients
from labjoint.structure.nlmode import (QUANTITY_ORDER, Drive, MeasuredMode, ModalBasis, _start,
                                       check_modal_model, lead)


def differences(basis: ModalBasis, a: str, b: str) -> np.ndarray:
    """D_j = phi_aj - phi_bj of every mode (eq. 5); refuses an unknown sensor or a pair
    whose relative motion no mode has."""
    for s in (a, b):
        missing = [i + 1 for i, m in enumerate(basis.modes) if s not in m.shape]
        if missing:
            raise InputError(f"no sensor {s!r} in mode {missing[0]}'s shape; sensors: "
                             f"{sorted(basis.modes[0].shape)}", field="joint.between")
    if a == b:
        raise InputError("a joint acts between two different sensors", field="joint.between")
    d = np.array([m.shape[a] - m.shape[b] for m in basis.modes])
    if not np.any(np.abs(d) > 1e-12):
        raise InputError(f"no measured mode moves {a} relative to {b}: the joint would do nothing",
                         field="joint.between")
    return d


def joint_participation(basis: ModalBasis, between: tuple[str, str],
                        vals: Mapping[str, Any] | None = None) -> np.ndarray:
    """D_j of eq. 5: the sensors' difference, mode j >= 2's replaced by a fitted
    ``modal.joint<j>`` where ``vals`` holds one (the joint's own participation)."""
    d = differences(basis, *between)
    vals = vals.valuesdict() if hasattr(vals, "valuesdict") else (vals or {})
    for j in range(2, d.size + 1):
        v = vals.get(f"modal.joint{j}")
        if v is not None:
            v = float(getattr(v, "value", v))
            if not np.isfinite(v):
                raise InputError(f"the joint's participation in mode {j} must be finite, got {v}",
                                 field=f"modal.joint{j}")
            d[j - 1] = v
    return d


def parameter_names(model: Model, n_modes: int) -> tuple[str, ...]:
    """The law's parameters, then ``modal.drive1..N`` and ``modal.mass2..N``."""
    return (*model.param_names, *(f"modal.drive{j}" for j in range(1, n_modes + 1)),
            *(f"modal.mass{j}" for j in range(2, n_modes + 1)))


@njit(cache=True)
def _pair_rates(vin, eta, deta, zb, zj, w2, cw, gd, gain, c, k, k3, f0, bw, jk, ev, mp, mh, mst):  # pragma: no cover
    u = 0.0
    du = 0.0
    for j in range(eta.size):
        u += gd[j, 0] * eta[j]
        du += gd[j, 0] * deta[j]
    fm = masing_eval(int(mp[0]), mp[1:], mh, mst, u) if mp[0] >= 0.0 else 0.0
    r = _rates(-fm, u, du, zb, zj, 1.0, c, k, k3, f0, bw, jk, ev)
    force = -r[1]                                  # F(u, u', z) of the law
    acc = gain * vin - cw * deta - w2 * eta - gd[:, 1] * force
    return acc, r[2], r[3]


@njit(cache=True)
def _pair(fine, h, substeps, w2, cw, gd, gain, c, k, k3, f0, bw, jk, ev, eta0, deta0, mp, mh, mst):  # pragma: no cover
    """(n, N, 3): eta, eta', eta'' of every mode at every sample (eq. 6); NaN from where it
    diverges."""
    n = (fine.size - 1) // (2 * substeps) + 1
    nm = eta0.size
    out = np.full((n, nm, 3), np.nan)
    eta, deta, zb, zj = eta0.copy(), deta0.copy(), 0.0, 0.0
    for i in range(n):
        a, _, _ = _pair_rates(fine[2 * i * substeps], eta, deta, zb, zj, w2, cw, gd, gain, c, k, k3,
                              f0, bw, jk, ev, mp, mh, mst)
        out[i, :, 0], out[i, :, 1], out[i, :, 2] = eta, deta, a
        if i == n - 1 or not np.all(np.abs(eta) < 1e6):
            break
        for s in range(substeps):
            j = 2 * (i * substeps + s)
            v0, vm, v1 = fine[j], fine[j + 1], fine[j + 2]
            a1, b1, c1 = _pair_rates(v0, eta, deta, zb, zj, w2, cw, gd, gain, c, k, k3, f0, bw, jk, ev,
                                     mp, mh, mst)
            e2, d2 = eta + 0.5 * h * deta, deta + 0.5 * h * a1
            a2, b2, c2 = _pair_rates(vm, e2, d2, zb + 0.5 * h * b1, zj + 0.5 * h * c1, w2, cw, gd, gain,
                                     c, k, k3, f0, bw, jk, ev, mp, mh, mst)
            e3, d3 = eta + 0.5 * h * d2, deta + 0.5 * h * a2
            a3, b3, c3 = _pair_rates(vm, e3, d3, zb + 0.5 * h * b2, zj + 0.5 * h * c2, w2, cw, gd, gain,
                                     c, k, k3, f0, bw, jk, ev, mp, mh, mst)
            e4, d4 = eta + h * d3, deta + h * a3
            a4, b4, c4 = _pair_rates(v1, e4, d4, zb + h * b3, zj + h * c3, w2, cw, gd, gain,
                                     c, k, k3, f0, bw, jk, ev, mp, mh, mst)
            eta = eta + h * (deta + 2.0 * d2 + 2.0 * d3 + d4) / 6.0
            deta = deta + h * (a1 + 2.0 * a2 + 2.0 * a3 + a4) / 6.0
            zb += h * (b1 + 2.0 * b2 + 2.0 * b3 + b4) / 6.0
            zj += h * (c1 + 2.0 * c2 + 2.0 * c3 + c4) / 6.0
            if jk[0] > 0.0:
                zj = min(max(zj, -jk[1] * (1.0 - jk[2])), jk[1] * (1.0 + jk[2]))
            if mp[0] >= 0.0:
                u = 0.0
                for jj in range(nm):
                    u += gd[jj, 0] * eta[jj]
                masing_commit(int(mp[0]), mp[1:], mh, mst, u)
    return out


def pair_states(model: Model | str, params: Mapping[str, Any], basis: ModalBasis, between: tuple[str, str],
                drive: Drive) -> np.ndarray:
    """(n, N, 3) eta, eta', eta'' of every measured mode with the joint ``model`` between the
    sensors ``between`` (eq. 6) under the segment's drive (volts, see :class:`Drive`)."""
    model = Model.parse(model) if isinstance(model, str) else model
    check_modal_model(model)
    if "inertia" in model.names:
        raise InputError("inertia cannot act between two points of the modal model", field="model")
    vals = {k: float(v.value if hasattr(v, "value") else v) for k, v in params.items()}
    d = joint_participation(basis, between, vals)
    nm = len(basis.modes)
    names = parameter_names(model, nm)
    missing = [p for p in names if p not in vals and not p.startswith("modal.mass")]
    if missing:
        raise InputError(f"missing parameter {missing[0]}", field=missing[0])
    mu = np.array([1.0] + [vals.get(f"modal.mass{j}", 1.0) for j in range(2, nm + 1)])
    if not np.all(np.isfinite(mu) & (mu > 0)):
        raise InputError("relative modal masses must be > 0", field="modal.mass")
    full = Model.parse("+".join(("inertia", *model.names)))
    _, c, k, k3, f0, bw, jk, ev = _coefficients(full, {**vals, "inertia.m": 1.0})
    w = 2 * np.pi * np.array([m.frequency_hz for m in basis.modes])
    cw = 2 * np.array([m.damping_ratio for m in basis.modes]) * w
    gain = np.array([vals[f"modal.drive{j}"] for j in range(1, nm + 1)])
    eta0, deta0 = np.zeros(nm), np.zeros(nm)
    for j in range(nm):
        eta0[j], deta0[j] = _start(drive, gain[j], w[j] ** 2, cw[j])
    gd = np.column_stack([d, d / mu])
    mp = masing_coefficients(full, {**vals, "inertia.m": 1.0})
    mh, mst = masing_state(float(d @ eta0))
    return _pair(drive.fine, 1.0 / (drive.fs * drive.substeps), drive.substeps, w * w, cw, gd, gain,
                 c, k, k3, f0, bw, jk, ev, eta0, deta0, mp, mh, mst)


def mode_reading(x: np.ndarray, mode: MeasuredMode, sensor: str, d: int,
                 fs: float | None = None) -> np.ndarray:
    """What mode j gives sensor s of order ``d`` per its coordinate's states ``x`` (n, 3):
    phi_sj eta_j^(d) for a real shape (eq. 7); a complex one, phi = a + i b, adds its
    imaginary part on the mode's quadrature, b eta_j^(d+1) / w_j (eq. 7b: nlmode eq. 3b with
    the measured b instead of a fitted h; i times a response is its derivative over w near
    the mode, where the mode's part of the response lies)."""
    y = mode.shape[sensor] * x[:, d]
    b = float(mode.shape_im.get(sensor, 0.0))
    if b:
        if fs is None:
            raise InputError("a complex mode's reading needs the states' sample rate", field="fs")
        y = y + b * lead(x, d, 2 * np.pi * mode.frequency_hz, fs)
    return y


def pair_response(states: np.ndarray, basis: ModalBasis, sensor: str, quantity: str,
                  fs: float | None = None) -> np.ndarray:
    """A sensor's reading y_s^(d) = sum_j phi_sj eta_j^(d) from :func:`pair_states` (eqs. 7,
    7b; ``fs``: the states' sample rate)."""
    if quantity not in QUANTITY_ORDER:
        raise InputError(f"must be one of {', '.join(QUANTITY_ORDER)}, got {quantity!r}", field="quantity")
    if any(sensor not in m.shape for m in basis.modes):
        raise InputError(f"no sensor {sensor!r} in the modes; sensors: {sorted(basis.modes[0].shape)}",
                         field="sensor")
    d = QUANTITY_ORDER[quantity]
    return sum(mode_reading(states[:, j, :], m, sensor, d, fs) for j, m in enumerate(basis.modes))


def relative_displacement(states: np.ndarray, basis: ModalBasis, between: tuple[str, str],
                          vals: Mapping[str, Any] | None = None) -> np.ndarray:
    """u = sum_j D_j eta_j at every sample (eq. 5; D_j fitted where ``vals`` holds them)."""
    return states[:, :, 0] @ joint_participation(basis, between, vals)


__all__ = ["differences", "joint_participation", "mode_reading", "pair_response", "pair_states", "parameter_names", "relative_displacement"]
