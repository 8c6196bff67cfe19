"""Forward prediction: the displacement a joint model gives under a force history.

A model whose effects include ``inertia`` is read as a single-degree-of-freedom equation
of motion, the applied force F(t) balancing every effect's force on the displacement y:

    m y'' + c y' + k y + k3 y^3 + k2 y^2 + dk max(y, 0) + F_c(y) + F_s(y) + F0 + z_bw + z_j = F(t)

(inertia m, viscous c, linear_stiffness k, cubic_stiffness k3, offset F0; the even laws
quadratic_stiffness k2, bilinear_stiffness dk and contact F_c = k_c max(sgn(k_c) y - g, 0);
saturating_stiffness F_s = k_s x_s tanh(y / x_s);
the hysteretic
forces of ``bouc_wen``, dz/dt = k0 y' - alpha |y'| |z|^(n-1) z - beta y' |z|^n (seed 001's
classical form; the Bouc-Wen benchmark's law with alpha = beta_B gamma_B, beta = beta_B
delta_B), and of
``coulomb``, a Jenkins element: dz/dt = k y' while z is inside its slip strengths or the
motion unloads it, z held within [-f_s (1 - asym), f_s (1 + asym)], asym from
``asymmetric_slip``, 0 without it). Other effects are refused by name.

Integrator (stated): classical fourth-order Runge-Kutta on (y, y', z_bw, z_j) with
``substeps`` steps per sample (20 by default, as the Bouc-Wen benchmark's own generator
integrates at 20x the sample rate); the force between samples is the band-limited
interpolation of the record (FFT resampling, which is exact for a periodic record and
accurate away from the ends of others). The state starts at rest (y = y' = z = 0) at the
first sample; ``periodic`` repeats the record until the response is periodic (the change
over one period below 1e-9 of its range, at most ``MAX_PERIODS``) and returns the last
period.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numba import njit
from scipy.signal import resample

from labjoint.errors import InputError
from labjoint.models.composition import Model
from labjoint.models.effects._masing import (IWAN, RICHARD_ABBOTT, iwan_params, masing_commit,
                                             masing_eval, ra_params)
from labjoint.models.effects.iwan import CHI_MIN
from labjoint.models.params import Parameters

DEFAULT_SUBSTEPS = 20
MAX_PERIODS = 50
MAX_COIL_SUBSTEPS = 2000
SUPPORTED = ("inertia", "viscous", "linear_stiffness", "cubic_stiffness", "offset",
             "bouc_wen", "coulomb", "quadratic_stiffness", "bilinear_stiffness", "contact",
             "saturating_stiffness", "asymmetric_slip")


@njit(cache=True)
def _rates(t_force, y, v, zb, zj, m, c, k, k3, f0, bw, jk, ev):  # pragma: no cover - numba
    k0, al, be, n = bw[0], bw[1], bw[2], bw[3]
    dzb = 0.0
    if k0 > 0.0:
        s = 1.0 if zb * v > 0.0 else (-1.0 if zb * v < 0.0 else 0.0)
        dzb = v * (k0 - abs(zb) ** n * (al * s + be))
    dzj = 0.0
    if jk[0] > 0.0:
        if (-jk[1] * (1.0 - jk[2]) < zj < jk[1] * (1.0 + jk[2])) or zj * v < 0.0:
            dzj = jk[0] * v
    f_even = ev[0] * y * y + ev[1] * max(y, 0.0)
    if ev[2] > 0.0:
        f_even += ev[2] * max(y - ev[3], 0.0)
    elif ev[2] < 0.0:
        f_even += ev[2] * max(-y - ev[3], 0.0)
    if ev[5] > 0.0:
        f_even += ev[4] * ev[5] * np.tanh(y / ev[5])
    a = (t_force - c * v - k * y - k3 * y * y * y - f_even - f0 - zb - zj) / m
    return v, a, dzb, dzj


@njit(cache=True)
def rk4_sample(fine, i, substeps, h, y, v, zb, zj, ci, m, c, k, k3, f0, bw, jk, ev, coil,
               mp, mh, mst):  # pragma: no cover
    """The state after sample ``i``'s ``substeps`` classical RK4 steps of :func:`_rates`;
    ``fine`` holds the drive at every half substep (shared by the joint-level simulator
    and the modal model, :mod:`labjoint.structure.nlmode`). ``coil`` = (Bl, R, L, G):
    with Bl > 0 the drive is the shaker's generator voltage u and the force is Bl ci, the
    coil current ci integrated with the rest by L ci' = G u - R ci - Bl v
    (:mod:`labjoint.models.shaker` S1); else the drive is the force and ci stays 0.
    ``mp`` = (kind, backbone parameters) of a Masing law (:func:`masing_coefficients`;
    kind < 0: none) whose state (``mh``, ``mst``: :func:`labjoint.models.effects._masing.masing_state`)
    is carried from step to step: each stage evaluates its force at the stage's
    displacement without moving the state, the step's end commits it."""
    bl = coil[0]
    mk = int(mp[0])
    bp = mp[1:]
    for s in range(substeps):
        j = 2 * (i * substeps + s)
        u0, um, u1 = fine[j], fine[j + 1], fine[j + 2]
        d1 = 0.0
        if bl > 0.0:
            d1 = (coil[3] * u0 - coil[1] * ci - bl * v) / coil[2]
            u0 = bl * ci
        if mk >= 0:
            u0 -= masing_eval(mk, bp, mh, mst, y)
        k1 = _rates(u0, y, v, zb, zj, m, c, k, k3, f0, bw, jk, ev)
        y2, v2, c2 = y + 0.5 * h * k1[0], v + 0.5 * h * k1[1], ci + 0.5 * h * d1
        d2, f2 = 0.0, um
        if bl > 0.0:
            d2 = (coil[3] * um - coil[1] * c2 - bl * v2) / coil[2]
            f2 = bl * c2
        if mk >= 0:
            f2 -= masing_eval(mk, bp, mh, mst, y2)
        k2 = _rates(f2, y2, v2, zb + 0.5 * h * k1[2], zj + 0.5 * h * k1[3], m, c, k, k3, f0, bw, jk, ev)
        y3, v3, c3 = y + 0.5 * h * k2[0], v + 0.5 * h * k2[1], ci + 0.5 * h * d2
        d3, f3 = 0.0, um
        if bl > 0.0:
            d3 = (coil[3] * um - coil[1] * c3 - bl * v3) / coil[2]
            f3 = bl * c3
        if mk >= 0:
            f3 -= masing_eval(mk, bp, mh, mst, y3)
        k3_ = _rates(f3, y3, v3, zb + 0.5 * h * k2[2], zj + 0.5 * h * k2[3], m, c, k, k3, f0, bw, jk, ev)
        y4, v4, c4 = y + h * k3_[0], v + h * k3_[1], ci + h * d3
        d4, f4 = 0.0, u1
        if bl > 0.0:
            d4 = (coil[3] * u1 - coil[1] * c4 - bl * v4) / coil[2]
            f4 = bl * c4
        if mk >= 0:
            f4 -= masing_eval(mk, bp, mh, mst, y4)
        k4 = _rates(f4, y4, v4, zb + h * k3_[2], zj + h * k3_[3], m, c, k, k3, f0, bw, jk, ev)
        y += h * (k1[0] + 2.0 * k2[0] + 2.0 * k3_[0] + k4[0]) / 6.0
        v += h * (k1[1] + 2.0 * k2[1] + 2.0 * k3_[1] + k4[1]) / 6.0
        zb += h * (k1[2] + 2.0 * k2[2] + 2.0 * k3_[2] + k4[2]) / 6.0
        zj += h * (k1[3] + 2.0 * k2[3] + 2.0 * k3_[3] + k4[3]) / 6.0
        ci += h * (d1 + 2.0 * d2 + 2.0 * d3 + d4) / 6.0
        if jk[0] > 0.0:
            zj = min(max(zj, -jk[1] * (1.0 - jk[2])), jk[1] * (1.0 + jk[2]))
        if mk >= 0:
            masing_commit(mk, bp, mh, mst, y)
    return y, v, zb, zj, ci


NO_COIL = np.zeros(4)
NO_MASING = np.array([-1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
#: Masing laws the RK4 integrators carry (an exact Iwan / Richard-Abbott by the extended
#: Masing rules of :mod:`labjoint.models.effects._masing`, the effects' own law)
MASING_LAWS = ("iwan", "richard_abbott")
_NO_HIST, _NO_ST = np.zeros((2, 1)), np.zeros(5)


def masing_coefficients(model: Model, params: Parameters | Mapping[str, Any]) -> np.ndarray:
    """(kind, backbone parameters) of the model's Masing law for :func:`rk4_sample`, as the
    effect itself simulates it (``iwan``: chi clipped at its CHI_MIN, no force with F_S or
    K_T <= 0; ``richard_abbott``: kp u with F_y <= 0); :data:`NO_MASING` without one."""
    laws = [n for n in model.names if n in MASING_LAWS]
    if not laws:
        return NO_MASING
    if len(laws) > 1:
        raise InputError(f"one Masing law at a time, not {' and '.join(laws)}", field="model")
    vals = model.values(params)[laws[0]]
    g = lambda p: float(vals[p])  # noqa: E731
    if laws[0] == "iwan":
        if not (g("F_S") > 0 and g("K_T") > 0):
            return NO_MASING
        return np.r_[IWAN, iwan_params(g("F_S"), g("K_T"), max(g("chi"), CHI_MIN), g("beta"))]
    if not g("F_y") > 0:    # a linear kp: a Richard-Abbott backbone with no curvature left
        return np.r_[RICHARD_ABBOTT, ra_params(g("kp"), g("kp"), 1.0, 1.0)]
    return np.r_[RICHARD_ABBOTT, ra_params(g("ke"), g("kp"), g("F_y"), g("n"))]


@njit(cache=True)
def _integrate(force_fine, h, m, c, k, k3, f0, bw, jk, ev, substeps, state, coil, mp, mh, mst):  # pragma: no cover
    """(n, 4): y, y', y'' and the coil current at every sample; ``force_fine`` holds the
    drive (force, or the shaker's voltage when ``coil`` has Bl > 0) at every half substep."""
    n = (force_fine.size - 1) // (2 * substeps) + 1
    out = np.empty((n, 4))
    y, v, zb, zj, ci = state[0], state[1], state[2], state[3], state[4]
    for i in range(n):
        f = coil[0] * ci if coil[0] > 0.0 else force_fine[2 * i * substeps]
        if mp[0] >= 0.0:
            f -= mst[3]          # the Masing force at y (the state's last committed point)
        r = _rates(f, y, v, zb, zj, m, c, k, k3, f0, bw, jk, ev)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = y, v, r[1], ci
        if i == n - 1:
            break
        y, v, zb, zj, ci = rk4_sample(force_fine, i, substeps, h, y, v, zb, zj, ci, m, c, k, k3, f0,
                                      bw, jk, ev, coil, mp, mh, mst)
    state[0], state[1], state[2], state[3], state[4] = y, v, zb, zj, ci
    return out


def check_simulable(model: Model) -> None:
    """Refuse a model that is not an equation of motion this module integrates."""
    other = [n for n in model.names if n not in SUPPORTED]
    if other:
        raise InputError(f"simulation supports {', '.join(SUPPORTED)}; not {other}",
                         field="model")
    if "inertia" not in model.names:
        raise InputError("simulating the displacement needs a mass: add inertia to the model",
                         field="model")
    if "asymmetric_slip" in model.names and "coulomb" not in model.names:
        raise InputError("the simulator applies asymmetric_slip to coulomb's slider only; "
                         "add coulomb to the model", field="model")


def _coefficients(model: Model, params: Parameters | Mapping[str, Any]) -> tuple:
    vals = model.values(params)
    g = lambda e, p: float(vals.get(e, {}).get(p, 0.0))  # noqa: E731
    m = g("inertia", "m")
    if not m > 0:
        raise InputError(f"the mass must be > 0 to simulate, got {m:g} kg", field="inertia.m")
    bw = np.zeros(4)
    if "bouc_wen" in vals:
        bw[:] = [g("bouc_wen", "k0"), g("bouc_wen", "alpha"), g("bouc_wen", "beta"), g("bouc_wen", "n")]
    jk = np.zeros(3)
    if "coulomb" in vals:
        jk[:] = [g("coulomb", "k"), g("coulomb", "f_s"), g("asymmetric_slip", "asym")]
    ev = np.array([g("quadratic_stiffness", "k2"), g("bilinear_stiffness", "dk"),
                   g("contact", "k_c"), g("contact", "gap"),
                   g("saturating_stiffness", "k_s"), g("saturating_stiffness", "x_s")])
    return (m, g("viscous", "c"), g("linear_stiffness", "k"), g("cubic_stiffness", "k3"),
            g("offset", "F0"), bw, jk, ev)


def fine_force(force: np.ndarray, substeps: int, periodic: bool) -> np.ndarray:
    """The force at every half substep (2 x substeps points per sample, and the last sample)."""
    f = np.asarray(force, dtype=float)
    r = 2 * substeps
    if periodic:
        return np.append(resample(f, f.size * r), f[0])
    pad = min(f.size, 256)        # odd-extended ends keep the FFT's wrap-around away
    ext = np.concatenate([2 * f[0] - f[pad:0:-1], f, 2 * f[-1] - f[-2:-pad - 2:-1]])
    fine = resample(ext, ext.size * r)
    return fine[pad * r: (pad + f.size - 1) * r + 1]


def simulate(model: Model | str, params: Parameters | Mapping[str, Any], force: np.ndarray,
             fs: float, *, substeps: int = DEFAULT_SUBSTEPS, periodic: bool = False) -> np.ndarray:
    """Displacement (m) at every sample of ``force`` (N) sampled at ``fs`` (module docstring)."""
    return simulate_states(model, params, force, fs, substeps=substeps, periodic=periodic)[:, 0]


def simulate_states(model: Model | str, params: Parameters | Mapping[str, Any], drive: np.ndarray,
                    fs: float, *, substeps: int = DEFAULT_SUBSTEPS, periodic: bool = False,
                    shaker: Any = None) -> np.ndarray:
    """(n, 4): displacement, velocity, acceleration and coil current at every sample of
    ``drive``: the force (N), or with ``shaker`` (:class:`labjoint.models.shaker.Shaker`)
    the generator voltage (V) through the shaker, whose armature rides on the mass
    (m + m_a, c + c_a, k + k_a) and whose coil is integrated with it (S1; with L = 0 the
    current is (G u - Bl v) / R: a force Bl G u / R and a damping Bl^2 / R)."""
    model = Model.parse(model)
    check_simulable(model)
    if not (np.isfinite(fs) and fs > 0):
        raise InputError(f"sample rate must be > 0, got {fs}", field="sample_rate_hz")
    f = np.asarray(drive, dtype=float)
    if f.ndim != 1 or f.size < 2 or not np.all(np.isfinite(f)):
        raise InputError(f"the {'voltage' if shaker else 'force'} must be a finite record of 2 or more "
                         "samples", field="voltage" if shaker else "force")
    if isinstance(substeps, bool) or int(substeps) < 1:
        raise InputError(f"must be a whole number >= 1, got {substeps!r}", field="substeps")
    m, c, k, k3, f0, bw, jk, ev = _coefficients(model, params)
    s = int(substeps)
    coil = NO_COIL
    if shaker is not None:
        sh = shaker
        m, c, k = (m + sh.armature_mass_kg, c + sh.suspension_damping_ns_per_m,
                   k + sh.suspension_stiffness_n_per_m)
        bl, R, L, G = (sh.force_factor_n_per_a, sh.coil_resistance_ohm, sh.coil_inductance_h,
                       sh.amplifier_gain_v_per_v)
        if L > 0:
            coil = np.array([bl, R, L, G])
            tau = L / R                       # RK4 stays stable and accurate with h <= tau / 2
            s = max(s, int(np.ceil(2.0 / (fs * tau))))
            if s > MAX_COIL_SUBSTEPS:
                raise InputError(f"the coil's time constant L / R = {tau:.3g} s needs {s} RK4 steps "
                                 f"per sample at {fs:g} Hz; its corner R / (2 pi L) = "
                                 f"{1 / (2 * np.pi * tau):.4g} Hz lies far above the record: give "
                                 "coil_inductance_h = 0", field="shaker.coil_inductance_h")
        else:
            f = f * (bl * G / R)
            c = c + bl * bl / R
    h = 1.0 / (fs * s)
    state = np.zeros(5)
    if not periodic:
        return _integrate(fine_force(f, s, False), h, m, c, k, k3, f0, bw, jk, ev, s, state, coil,
                          NO_MASING, _NO_HIST, _NO_ST)
    one = fine_force(f, s, True)
    prev = None
    for _ in range(MAX_PERIODS):
        y = _integrate(one, h, m, c, k, k3, f0, bw, jk, ev, s, state, coil, NO_MASING, _NO_HIST, _NO_ST)
        if prev is not None and np.max(np.abs(y[:, 0] - prev)) <= 1e-9 * max(np.ptp(y[:, 0]), 1e-300):
            break
        prev = y[:, 0]
    return y[:-1] if y.shape[0] > f.size else y


def shaker_outputs(states: np.ndarray, shaker: Any, volts: np.ndarray) -> dict[str, np.ndarray]:
    """Per sample of :func:`simulate_states` with a shaker: the displacement, velocity and
    acceleration of the driven mass, the coil current and the force on the structure,
    F = Bl i - m_a a - c_a v - k_a x (:mod:`labjoint.models.shaker` S2): the per-volt and
    the per-newton responses both follow."""
    x, v, a, i = states.T
    sh = shaker
    if sh.coil_inductance_h == 0:
        i = (sh.amplifier_gain_v_per_v * np.asarray(volts, float) - sh.force_factor_n_per_a * v) / sh.coil_resistance_ohm
    F = sh.force_factor_n_per_a * i - sh.armature_mass_kg * a - sh.suspension_damping_ns_per_m * v \
        - sh.suspension_stiffness_n_per_m * x
    return {"displacement": x, "velocity": v, "acceleration": a, "coil_current": i, "force": F}
