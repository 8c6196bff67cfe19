"""A structure nobody can describe: a modal model from measured modes with one nonlinear
mode (issue 29 item 5), its responses in the measured quantities (item 2).

The structure is its measured linear modes (natural frequency f_j, damping ratio zeta_j,
from ``labjoint modes``) driven through the shaker by the amplifier voltage V(t). Mode 1
carries the joint: its coordinate q (unit modal mass; q is the mode-1 displacement at
the reference sensor, so the mode-1 participation of the reference sensor is 1) obeys

    q'' + F_joint(q, q', history) = b V(t)                                     (1)

where F_joint is the joint model (any effects the forward simulator integrates:
linear_stiffness k = w_1^2, viscous c = 2 zeta_1 w_1, quadratic_stiffness, cubic_stiffness,
bilinear_stiffness, contact, saturating_stiffness, coulomb (+ asymmetric_slip), bouc_wen, offset, and the Masing
laws iwan (Segalman's micro- to macro-slip) and richard_abbott; per unit
modal mass, so k2 is in N/m^2 per kg, and so on) and b (``modal.drive``, m/s^2 per volt)
the modal force per volt. The other modes are linear and each driven by V:

    p_j'' + 2 zeta_j w_j p_j' + w_j^2 p_j = V(t)                               (2)

A sensor s measuring displacement, velocity or acceleration reads, from the states,

    y_s = phi_s q^(d) + sum_j g_sj p_j^(d),   d = 0, 1, 2 by the sensor's quantity  (3)

(phi_s: ``modal.phi1.<s>``, mode-1 participation relative to the reference; g_sj:
``modal.g<j>.<s>``, mode j's drive x sensor participation per volt). The acceleration is
the rate of the velocity at the sample, exact for the integrated states; nothing
measured is ever integrated or differentiated. Modes measured complex (a sensor more
than 10 deg from real: non-proportional damping, such as a shaker's back-EMF at one
point) add a quadrature participation per mode and sensor (``modal.h<j>.<s>``;
``modal.h1.<s>`` off the reference, where mode 1 is real by definition):

    y_s += h_s1 q^(d+1) / w_1 + sum_j h_sj p_j^(d+1) / w_j                      (3b)

(:func:`lead`; w_j the mode's measured or fitted natural frequency).

The shaker path's low-frequency roll-off (an AC-coupled amplifier, the armature's
suspension taking the force at low frequency): a first-order high-pass of corner f_hp
(``shaker.highpass_hz``, fitted; 0 = none) between the voltage and every mode's force,

    V_hp' = V' - 2 pi f_hp V_hp                                                 (4)

(BERT: the velocity per volt leads the modal model by 18 deg at 5 Hz, 11 at 9 Hz, 5 at
17 Hz, as tan(phi) = f_hp / f with f_hp ~ 1.6 Hz). The path's lag at high frequency (the
coil's L / R, a sensor's decoder, the channels' anti-alias filters: what lags the
response behind the voltage, as one first-order lag of time constant tau,
``shaker.lag_s``, fitted; 0 = none) on the same voltage,

    tau V_lag' = V - V_lag                                                        (4b)

(BERT: tau ~ 0.3 ms, 11 deg at mode 2's 97 Hz; the linear fit of the 0.30 V random test
on itself leaves 19.6 % without it, 17.0 % with it).

The shaker: with the force not measured, the shaker between voltage and structure
(:class:`labjoint.models.shaker.Shaker`: coil R, L, force factor Bl, armature m_a, k_s,
c_s) enters the modes as products only: Bl G / R times the drive-point participation
(b, g_sj), the back-EMF Bl^2 / R and the suspension c_s as viscous damping of each mode,
m_a and k_s as modal mass and stiffness at the drive point (merged with f_j, zeta_j).
The coil's L / R is a first-order lag whose corner (R / (2 pi L), kHz for a modal shaker)
lies far above the modes; the model takes it as zero. :func:`shaker_identifiable` states
which shaker parameters a voltage-driven record can see (none on its own: each is
refused by name). The model is per volt; a per-newton one needs the force or the
drive-point participation, which these records do not hold.

Integrator (stated): classical 4th-order Runge-Kutta with ``substeps`` steps per sample
(at least 4, and w h <= 0.1 at 1.5 x the highest measured mode)
on (q, q', z_bouc_wen, z_jenkins) by the forward simulator's own rates
(:mod:`labjoint.models.simulate`, the same laws), a Masing law's reversal stack carried
from step to step (each stage's force at its own q from the step's start, committed at
the step's end: :func:`labjoint.models.effects._masing.masing_eval`, the effect's own
extended Masing rules, exact for a parallel Iwan network), the voltage between samples
band-limited (its ``fine_force``). A segment starts from the linear steady state of its
drive's fundamental (a steady sine) or from rest (a record that starts at rest).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numba import njit
from scipy.signal import lfilter

from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.models.effects._masing import IWAN, masing_state
from labjoint.models.simulate import (MASING_LAWS, NO_COIL, SUPPORTED, _coefficients, _rates, fine_force,
                                     NO_MASING, masing_coefficients, rk4_sample)
# the measured modes (their own module; imported from here as before)
from labjoint.structure.modal_basis import (MeasuredMode, ModalBasis, basis_from_json,  # noqa: F401
                                            load_basis)

SUBSTEPS = 4
MAX_WH = 0.1            # RK4 step: w h at most this at 1.5x the highest mode (phase error ~1e-7 a step)
#: effects that can act on a mode's coordinate (the forward simulator's laws; the modal
#: mass is the model's own, so ``inertia`` is not one of them)
MODAL_EFFECTS = (*(n for n in SUPPORTED if n != "inertia"), *MASING_LAWS)
QUANTITY_ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}
DIVERGED = 1e6          # |q| above this many metres: the simulation has diverged


def check_modal_model(model: Model) -> None:
    """Refuse an effect that cannot act on a mode's coordinate, naming it."""
    bad = [n for n in model.names if n not in MODAL_EFFECTS]
    if bad:
        raise InputError(f"{', '.join(bad)} cannot act on a mode's coordinate (the modal kind "
                         f"takes {', '.join(MODAL_EFFECTS)}; the modal mass is built in)",
                         field="model")
    if "asymmetric_slip" in model.names and "coulomb" not in model.names:
        raise InputError("asymmetric_slip acts on coulomb's slider; add coulomb", field="model")


@njit(cache=True)
def _mode_coil(drive_fine, h, m, c, k, k3, f0, bw, jk, ev, substeps, y0, v0, coil, ci0, mp, mh, mst):  # pragma: no cover
    """(n, 4): q, q', q'' and the coil current at every sample (eq. 1; with ``coil`` = (Bl,
    R, L, G), Bl > 0, the drive is a voltage through the coil of
    :func:`labjoint.models.simulate.rk4_sample`); NaN from where it diverges. ``mp``,
    ``mh``, ``mst``: a Masing law and its state (relaxed at y0), :func:`rk4_sample`."""
    n = (drive_fine.size - 1) // (2 * substeps) + 1
    out = np.full((n, 4), np.nan)
    y, v, zb, zj, ci = y0, v0, 0.0, 0.0, ci0
    for i in range(n):
        fm = mst[3] if mp[0] >= 0.0 else 0.0     # the Masing force at y
        f = coil[0] * ci if coil[0] > 0.0 else drive_fine[2 * i * substeps]
        r = _rates(f - fm, y, v, zb, zj, m, c, k, k3, f0, bw, jk, ev)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = y, v, r[1], ci
        if i == n - 1 or not abs(y) < 1e6:
            break
        y, v, zb, zj, ci = rk4_sample(drive_fine, i, substeps, h, y, v, zb, zj, ci, m, c, k, k3, f0,
                                      bw, jk, ev, coil, mp, mh, mst)
    return out


def _mode(drive_fine, h, m, c, k, k3, f0, bw, jk, ev, substeps, y0, v0, mp=NO_MASING, mh=None,
          mst=None) -> np.ndarray:
    """(n, 3): q, q', q'' at every sample (eq. 1) under a drive per unit modal mass, with the
    Masing law ``mp`` (:func:`labjoint.models.simulate.masing_coefficients`) if any."""
    if mh is None:
        mh, mst = masing_state(y0)
    return _mode_coil(drive_fine, h, m, c, k, k3, f0, bw, jk, ev, substeps, y0, v0, NO_COIL, 0.0,
                      mp, mh, mst)[:, :3]


@dataclass(frozen=True)
class Drive:
    """One segment's voltage at half substeps, its sample rate and how it starts: the drive's
    fundamental phasor (V, at ``frequency_hz``, time from the segment's first sample) for a
    steady sine, else None (from rest)."""

    fine: np.ndarray
    fs: float
    n: int
    frequency_hz: float | None = None
    phasor: complex = 0j
    substeps: int = SUBSTEPS

    @classmethod
    def of(cls, volts: np.ndarray, fs: float, frequency_hz: float | None = None,
           highest_hz: float = 0.0) -> Drive:
        """``highest_hz``: the highest mode; the substeps keep w h <= ``MAX_WH`` at 1.5x it."""
        v = np.asarray(volts, float)
        ph = 0j
        if frequency_hz:
            t = np.arange(v.size) / fs
            A = np.column_stack([np.cos(2 * np.pi * frequency_hz * t), np.sin(2 * np.pi * frequency_hz * t),
                                 np.ones_like(t)])
            a, b, _ = np.linalg.lstsq(A, v, rcond=None)[0]
            ph = complex(a, -b)                  # V ~ Re(ph e^{i w t})
        sub = max(SUBSTEPS, int(np.ceil(1.5 * 2 * np.pi * highest_hz / (MAX_WH * fs))))
        return cls(fine_force(v, sub, False), float(fs), v.size, frequency_hz, ph, sub)

    def highpassed(self, corner_hz: float) -> Drive:
        """The drive through the shaker path's first-order high-pass s / (s + a), a = 2 pi
        ``corner_hz`` (eq. 4), on the fine grid (backward Euler, a dt < 1e-3 there); a
        steady sine's filter starts in its steady state, a record's at rest."""
        if not corner_hz > 0:
            return self
        a = 2 * np.pi * corner_hz
        dt = 1.0 / (self.fs * 2 * self.substeps)
        al = 1.0 / (1.0 + a * dt)
        x = self.fine
        ph = self.phasor
        if self.frequency_hz:
            w = 2 * np.pi * self.frequency_hz
            ph = ph * (1j * w) / (1j * w + a)
        y0 = float(ph.real) if self.frequency_hz else 0.0
        y = lfilter([al, -al], [1.0, -al], x, zi=[y0 - al * x[0]])[0]
        return replace(self, fine=y, phasor=ph)


    def lagged(self, tau_s: float) -> Drive:
        """The drive through the path's first-order lag 1 / (1 + s tau) (eq. 4b) on the fine
        grid, exact for an input linear between fine samples; a steady sine's lag starts
        in its steady state, a record's at rest."""
        if not tau_s > 0:
            return self
        dt = 1.0 / (self.fs * 2 * self.substeps)
        a = float(np.exp(-dt / tau_s))
        b0 = 1.0 - tau_s * (1.0 - a) / dt
        b1 = (1.0 - a) - b0
        x = self.fine
        ph = self.phasor
        if self.frequency_hz:
            ph = ph / (1.0 + 1j * 2 * np.pi * self.frequency_hz * tau_s)
        y0 = float(ph.real) if self.frequency_hz else 0.0
        y = lfilter([b0, b1], [1.0, -a], x[1:], zi=[a * y0 + b1 * x[0]])[0]
        return replace(self, fine=np.concatenate([[y0], y]), phasor=ph)


def _start(d: Drive, gain: float, k: float, c: float) -> tuple[float, float]:
    """The linear steady state (q, q') at the first sample under the drive's fundamental."""
    if not d.frequency_hz:
        return 0.0, 0.0
    w = 2 * np.pi * d.frequency_hz
    q = gain * d.phasor / (k - w * w + 1j * c * w)
    return float(q.real), float((1j * w * q).real)


def mode_states(model: Model, params: Mapping[str, Any], drive: Drive) -> np.ndarray:
    """(n, 3) q, q', q'' of the nonlinear mode (eq. 1) under the segment's drive."""
    vals = {k: float(v.value if hasattr(v, "value") else v) for k, v in params.items()}
    vals["inertia.m"] = 1.0
    full = Model.parse("+".join(("inertia", *model.names)))
    m, c, k, k3, f0, bw, jk, ev = _coefficients(full, vals)
    mp = masing_coefficients(full, vals)
    b = vals["modal.drive"]
    y0, v0 = _start(drive, b, k + _masing_stiffness(mp), c)
    mh, mst = masing_state(y0)
    return _mode(b * drive.fine, 1.0 / (drive.fs * drive.substeps), m, c, k, k3, f0, bw, jk, ev,
                 drive.substeps, y0, v0, mp, mh, mst)


def _masing_stiffness(mp: np.ndarray) -> float:
    """The Masing law's stuck stiffness (its backbone's slope at 0), for the linear steady
    start: iwan F_S (1 + beta) / (D phi_max) = K_T; richard_abbott (ke - kp) + kp."""
    if mp[0] < 0:
        return 0.0
    if int(mp[0]) == IWAN:
        return float(mp[1] * (1.0 + mp[4]) / (mp[3] * mp[2]))
    return float(mp[1] + mp[4])


def linear_states(mode: MeasuredMode, drive: Drive) -> np.ndarray:
    """(n, 3) p, p', p'' of a linear mode under unit gain (eq. 2)."""
    w = 2 * np.pi * mode.frequency_hz
    c, k = 2 * mode.damping_ratio * w, w * w
    y0, v0 = _start(drive, 1.0, k, c)
    z3 = np.zeros(3)
    return _mode(drive.fine, 1.0 / (drive.fs * drive.substeps), 1.0, c, k, 0.0, 0.0, np.zeros(4), z3,
                 np.zeros(4), drive.substeps, y0, v0, NO_MASING, *masing_state(y0))


def response(q: np.ndarray, lin: Sequence[np.ndarray], quantity: str, phi: float,
             gains: Sequence[float]) -> np.ndarray:
    """A sensor's reading from the states (eq. 3)."""
    d = QUANTITY_ORDER[quantity]
    y = phi * q[:, d]
    for g, p in zip(gains, lin):
        y = y + g * p[:, d]
    return y


def lead(states: np.ndarray, d: int, w: float, fs: float) -> np.ndarray:
    """A mode's quadrature part at a sensor of order ``d`` (eq. 3b): its (d+1)-th derivative
    over w (a complex residue pair is a numerator a s + b over the mode's poles, so a
    complex mode reads g p^(d) + h p^(d+1) / w). The states hold p, p', p''; the third
    derivative by central differences: a phase of exactly 90 deg and a magnitude
    sin(w h) / (w h), which the fitted h takes up around the mode."""
    if d < 2:
        return states[:, d + 1] / w
    return np.gradient(states[:, 2], 1.0 / fs) / w


def shaker_identifiable(names: Sequence[str]) -> None:
    """Refuse shaker parameters a voltage-driven record cannot see (module docstring)."""
    why = {"force_factor_n_per_a": "seen only as Bl G / R times the drive-point participation "
                                   "(modal.drive)",
           "coil_resistance_ohm": "seen only in Bl G / R (modal.drive) and Bl^2 / R (damping)",
           "amplifier_gain_v_per_v": "seen only in Bl G / R (modal.drive)",
           "armature_mass_kg": "merged with the modal mass at the drive point (the mode's frequency)",
           "suspension_stiffness_n_per_m": "merged with the modal stiffness (the mode's frequency)",
           "suspension_damping_ns_per_m": "merged with the mode's viscous damping",
           "coil_inductance_h": "its corner R / (2 pi L) lies far above the modes: no phase the "
                                "record resolves"}
    for n in names:
        if n not in why:
            raise InputError(f"unknown shaker parameter; known: {sorted(why)}", field=f"shaker.{n}")
        raise InputError(f"not identifiable from a voltage-driven record without a force: {why[n]}",
                         field=f"shaker.{n}")

