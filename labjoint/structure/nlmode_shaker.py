"""The electrodynamic shaker between the voltage and mode 1 of the modal model (issue 29
items 3 and 5): the nonlinear mode of :mod:`labjoint.structure.nlmode` driven through the
shaker of :mod:`labjoint.models.shaker` at its drive point instead of by "a voltage with
a fitted gain".

Mode 1's coordinate q is its displacement at the reference sensor; the drive point d (a
sensor of the modes) moves x_d = phi_d q (phi_d: its mode-1 shape over the reference's);
m_d is mode 1's modal mass at the drive point (kg; ``mode1.mass_kg``, as in
:mod:`labjoint.models.shaker_fit`), so phi_d^2 m_d is the modal mass of q. With the force
F on the structure at d, the shaker's S1 and S2 and the joint law F_joint per unit modal
mass (the structure's own: what the structure does without the shaker):

    q'' + F_joint(q, q', z) = F / (phi_d m_d)                                       (H1)
    F = Bl i - m_a x_d'' - c_a x_d' - k_a x_d                                       (H2 = S2)
    L i' + R i + Bl x_d' = G V_hp(t)                                                (H3 = S1)

V_hp: the recorded voltage through the amplifier's high-pass (nlmode eq. 4; its corner
``shaker.highpass_hz`` fitted unless bounded to 0). Substituted,

    (1 + m_a / m_d) q'' + F_joint + (c_a q' + k_a q) / m_d = Bl i / (phi_d m_d)     (H4)

integrated by the forward simulator's RK4 step with its coil (``rk4_sample``'s coil
argument, i scaled by 1 / (phi_d sqrt(m_d)) so that one Bl' = Bl / sqrt(m_d) serves H3 and
H4, G' = G / (phi_d sqrt(m_d))). With L = 0, or a coil corner R / (2 pi L) that the
drive's RK4 step cannot resolve (h > L / (2 R)) and that lies above ``COIL_NEGLECT`` x mode
1's frequency (a lag of at most 5.7 degrees there; stated in the fit's drive path; below it the coil is refused by name), i =
(G V_hp - Bl x_d') / R: a drive Bl G / (R phi_d m_d) and a damping Bl^2 / (R m_d).

What a voltage-driven record identifies is :func:`labjoint.models.shaker_fit.require_voltage_only`'s
(one set of rules): the armature must be given, and two of Bl, R and ``mode1.mass_kg``;
the third is fitted with the joint (it sets the drive, Bl G / (R phi_d m_d)). The other
modes stay driven per volt (their gains projected, eq. 3): the shaker's loading of them is
in their fitted f_j, zeta_j. The per-newton model is H1 alone (the structure), and the force
H2 is returned with the states (mode 1's share of the drive point's motion).

With the joint between two points (:mod:`labjoint.structure.nlmode_pair`) the shaker's
force acts at d on every mode. The measured modes are then the structure as a per-volt
test measures it: the joint at rest and the shaker attached (its armature, suspension and
the coil's back-EMF Bl^2 / R at d are in f_j, zeta_j and the shapes), so with mode j's
coordinate eta_j (its displacement at the reference), phi_dj its shape at d over the
reference's and M_j = mu_j M_1 its modal mass (mu_j: ``modal.mass<j>``, mu_1 = 1),
M_1 = phi_d1^2 (m_d + m_a) (m_d: the structure's own modal mass at d, ``mode1.mass_kg``,
as above; the armature moves with d), the electromagnetic force Bl G V_hp / R less the
back-EMF already in the modes drives mode j by (nlmode_pair eq. 6's g_j)

    g_j = phi_dj Bl G / (R mu_j phi_d1^2 (m_d + m_a))   (m/s^2 per V)              (P1)

and the force on the structure at d is H2 with x_d = sum_j phi_dj eta_j and the coil
current of H3 with L = 0:

    F = Bl (G V_hp - Bl x_d') / R - m_a x_d'' - c_a x_d' - k_a x_d                   (P2)

The joint law stays per unit modal mass of mode 1 (N/kg: the physical force over M_1).
The coil's lag is left out when its corner R / (2 pi L) lies at least ``COIL_NEGLECT`` x
above the highest mode (at most 5.7 degrees there), else refused by name: the two-point
model does not integrate the coil. The identifiability rules are the single mode's.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.models.shaker import SYMBOLS, Shaker, checked_values
from labjoint.models.shaker_fit import require_voltage_only
from labjoint.models.effects._masing import masing_state
from labjoint.models.simulate import _coefficients, masing_coefficients
from labjoint.structure.nlmode import Drive, ModalBasis, _masing_stiffness, _mode_coil

COIL_NEGLECT = 10.0       # the coil's lag is left out when its corner is above this x mode 1 (<= 5.7 deg there)


@dataclass(frozen=True)
class ShakerPath:
    """The shaker's given parameters (``[shaker]`` table), the drive-point sensor, and
    ``mode1.mass_kg`` when given; ``free``: the parameter the records determine."""

    given: tuple[tuple[str, float], ...]
    drive_point: str
    phi_d: float
    modal_mass_kg: float | None = None
    free: str | None = None

    @classmethod
    def of(cls, given: Mapping[str, Any], drive_point: str, basis: ModalBasis,
           modal_mass_kg: float | None = None, where: str = "") -> ShakerPath:
        """Check the given parameters by the rules of a test without a force (refusals by
        name) and the drive point against the modes."""
        vals = checked_values(given, where)
        struct = {} if modal_mass_kg is None else {"mode1.mass_kg": float(modal_mass_kg)}
        if modal_mass_kg is not None and not (np.isfinite(modal_mass_kg) and modal_mass_kg > 0):
            raise InputError(f"must be a positive mass in kg, got {modal_mass_kg}", field="mode1.mass_kg")
        free = require_voltage_only(vals, struct)
        shape = basis.modes[0].shape
        if drive_point not in shape:
            raise InputError(f"the drive point {drive_point!r} is not a sensor of the modes "
                             f"({sorted(shape)}); the shaker acts on mode 1 there", field="drive_point")
        phi = shape[drive_point] / shape.get(basis.reference, 1.0)
        if not (np.isfinite(phi) and abs(phi) > 1e-9):
            raise InputError(f"mode 1 does not move the drive point {drive_point!r} (shape {phi:g}): "
                             "the shaker cannot drive it", field="drive_point")
        return cls(tuple(sorted(vals.items())), drive_point, float(phi),
                   None if modal_mass_kg is None else float(modal_mass_kg), free)

    def shaker(self, vals: Mapping[str, float]) -> tuple[Shaker, float]:
        """The complete shaker and m_d: the given values, the free one from ``vals``."""
        d = dict(self.given)
        d.setdefault("coil_inductance_h", 0.0)
        m_d = self.modal_mass_kg
        if self.free == "mode1.mass_kg":
            m_d = float(vals["mode1.mass_kg"])
        elif self.free:
            d[self.free.split(".", 1)[1]] = float(vals[self.free])
        if not (m_d is not None and m_d > 0):
            raise InputError(f"mode 1's modal mass must be > 0, got {m_d}", field="mode1.mass_kg")
        return Shaker(**d), float(m_d)

    def drive_gain(self, vals: Mapping[str, float]) -> float:
        """Bl G / (R phi_d m_d): the modal drive per volt without back-EMF (m/s^2 per V)."""
        sh, m_d = self.shaker(vals)
        return sh.force_factor_n_per_a * sh.amplifier_gain_v_per_v / (sh.coil_resistance_ohm * self.phi_d * m_d)

    def free_start(self, gain: float) -> dict[str, float]:
        """The free parameter from a fitted per-volt drive ``gain`` (the drive_gain's inverse)."""
        if not self.free:
            return {}
        d = dict(self.given)
        b = abs(gain) if gain else 1.0
        m_d = self.modal_mass_kg
        if self.free == "mode1.mass_kg":
            v = d["force_factor_n_per_a"] * d.get("amplifier_gain_v_per_v", 1.0) / (
                d["coil_resistance_ohm"] * abs(self.phi_d) * b)
        elif self.free == "shaker.force_factor_n_per_a":
            v = b * d["coil_resistance_ohm"] * abs(self.phi_d) * m_d / d.get("amplifier_gain_v_per_v", 1.0)
        else:
            v = d["force_factor_n_per_a"] * d.get("amplifier_gain_v_per_v", 1.0) / (b * abs(self.phi_d) * m_d)
        return {self.free: float(v)}

    def structure_start(self, w1: float, zeta1: float, vals: Mapping[str, float]) -> dict[str, float]:
        """The structure's own k and c per unit modal mass from the measured (shaker-loaded)
        mode 1: k = w1^2 (1 + m_a/m_d) - k_a/m_d, c = 2 zeta1 w1 (1 + m_a/m_d) - (c_a + Bl^2/R)/m_d
        (at least a tenth of the measured c)."""
        sh, m_d = self.shaker(vals)
        mu = 1 + sh.armature_mass_kg / m_d
        k = w1 * w1 * mu - sh.suspension_stiffness_n_per_m / m_d
        c0 = 2 * zeta1 * w1
        c = c0 * mu - (sh.suspension_damping_ns_per_m + sh.force_factor_n_per_a ** 2 / sh.coil_resistance_ohm) / m_d
        return {"linear_stiffness.k": float(max(k, 0.1 * w1 * w1)), "viscous.c": float(max(c, 0.1 * c0))}

    @property
    def free_unit(self) -> str:
        """The unit of the fitted parameter (``free``)."""
        return {"mode1.mass_kg": "kg", "shaker.force_factor_n_per_a": "N/A"}.get(self.free or "", "ohm")

    def bounds(self) -> dict[str, tuple[float, float]]:
        return {self.free: (0.0, np.inf)} if self.free else {}

    def coil_used(self, drive: Drive, vals: Mapping[str, float], mode_hz: float) -> bool:
        """Whether the coil's lag is integrated (module doc); refuses a coil corner the step
        cannot resolve that lies within ``COIL_NEGLECT`` x the highest mode."""
        sh, _ = self.shaker(vals)
        L, R = sh.coil_inductance_h, sh.coil_resistance_ohm
        if L == 0:
            return False
        h = 1.0 / (drive.fs * drive.substeps)
        if h <= L / (2 * R):
            return True
        corner = R / (2 * np.pi * L)
        if corner >= COIL_NEGLECT * mode_hz:
            return False
        raise InputError(f"the coil's corner R / (2 pi L) = {corner:.4g} Hz is within {COIL_NEGLECT:g}x "
                         f"mode 1 ({mode_hz:.4g} Hz) but needs an RK4 step below "
                         f"{L / (2 * R):.3g} s (the drive's is {h:.3g} s)", field="shaker.coil_inductance_h")

    def states(self, model: Model, vals: Mapping[str, float], drive: Drive, mode_hz: float) -> np.ndarray:
        """(n, 4): q, q', q'' (H4) and the force on the structure F (H2) at every sample."""
        sh, m_d = self.shaker(vals)
        full = Model.parse("+".join(("inertia", *model.names)))
        mu = 1 + sh.armature_mass_kg / m_d
        m, c, k, k3, f0, bw, jk, ev = _coefficients(full, {**vals, "inertia.m": mu})
        mp = masing_coefficients(full, {**vals, "inertia.m": mu})    # iwan, richard_abbott
        c = c + sh.suspension_damping_ns_per_m / m_d
        k = k + sh.suspension_stiffness_n_per_m / m_d
        bl, R, L, G = (sh.force_factor_n_per_a, sh.coil_resistance_ohm, sh.coil_inductance_h,
                       sh.amplifier_gain_v_per_v)
        p = self.phi_d
        h = 1.0 / (drive.fs * drive.substeps)
        if self.coil_used(drive, vals, mode_hz):
            s = 1.0 / (p * np.sqrt(m_d))
            coil = np.array([bl / np.sqrt(m_d), R, L, s * G])
            y0, v0, i0 = _steady(drive, m, k + _masing_stiffness(mp), c, coil)
            out = _mode_coil(drive.fine, h, m, c, k, k3, f0, bw, jk, ev, drive.substeps, y0, v0, coil, i0,
                             mp, *masing_state(y0))
            i = out[:, 3] / s
        else:
            gain = bl * G / (R * p * m_d)
            y0, v0, _ = _steady(drive, m, k + _masing_stiffness(mp), c + bl * bl / (R * m_d),
                                np.array([gain, 1.0, 0.0, 1.0]))
            out = _mode_coil(gain * drive.fine, h, m, c + bl * bl / (R * m_d), k, k3, f0, bw, jk, ev,
                             drive.substeps, y0, v0, np.zeros(4), 0.0, mp, *masing_state(y0))
            v_hp = drive.fine[::2 * drive.substeps][:out.shape[0]]
            i = (G * v_hp - bl * p * out[:, 1]) / R
        F = bl * i - p * (sh.armature_mass_kg * out[:, 2] + sh.suspension_damping_ns_per_m * out[:, 1]
                          + sh.suspension_stiffness_n_per_m * out[:, 0])
        return np.column_stack([out[:, :3], F])

    def participations(self, basis: ModalBasis) -> np.ndarray:
        """phi_dj: every mode's shape at the drive point over the reference's (P1)."""
        out = []
        for j, mode in enumerate(basis.modes):
            if self.drive_point not in mode.shape:
                raise InputError(f"the drive point {self.drive_point!r} is not in mode {j + 1}'s shape "
                                 f"({sorted(mode.shape)}); the shaker acts on every mode there",
                                 field="drive_point")
            out.append(mode.shape[self.drive_point] / mode.shape.get(basis.reference, 1.0))
        return np.array(out, float)

    def pair_drives(self, vals: Mapping[str, float], basis: ModalBasis) -> dict[str, float]:
        """Every mode's drive per volt ``modal.drive<j>`` through the shaker (P1), the
        relative modal masses ``modal.mass<j>`` from ``vals`` (default 1)."""
        sh, m_d = self.shaker(vals)
        phi = self.participations(basis)
        b = sh.force_factor_n_per_a * sh.amplifier_gain_v_per_v / (
            sh.coil_resistance_ohm * phi[0] ** 2 * (m_d + sh.armature_mass_kg))
        mu = [1.0] + [float(vals.get(f"modal.mass{j}", 1.0)) for j in range(2, phi.size + 1)]
        return {f"modal.drive{j + 1}": float(phi[j] * b / mu[j]) for j in range(phi.size)}

    def pair_free_start(self, g1: float) -> dict[str, float]:
        """The free parameter from mode 1's fitted drive per volt ``g1`` (P1 inverted)."""
        if not self.free:
            return {}
        d = dict(self.given)
        bl, r = d.get("force_factor_n_per_a"), d.get("coil_resistance_ohm")
        G, m_a = d.get("amplifier_gain_v_per_v", 1.0), d["armature_mass_kg"]
        b = abs(g1 * self.phi_d) or 1.0          # = Bl G / (R (m_d + m_a)) by P1
        if self.free == "mode1.mass_kg":
            return {self.free: float(max(bl * G / (r * b) - m_a, 1e-3 * m_a, 1e-9))}
        m = float(self.modal_mass_kg) + m_a
        if self.free == "shaker.force_factor_n_per_a":
            return {self.free: float(b * r * m / G)}
        return {self.free: float(bl * G / (b * m))}

    def check_pair_coil(self, vals: Mapping[str, float], highest_hz: float) -> None:
        """Refuse a coil whose corner lies within ``COIL_NEGLECT`` x the highest mode (the
        two-point model leaves the coil's lag out; module doc)."""
        sh, _ = self.shaker(vals)
        L, R = sh.coil_inductance_h, sh.coil_resistance_ohm
        if L > 0 and R / (2 * np.pi * L) < COIL_NEGLECT * highest_hz:
            raise InputError(f"the coil's corner R / (2 pi L) = {R / (2 * np.pi * L):.4g} Hz is within "
                             f"{COIL_NEGLECT:g}x the highest mode ({highest_hz:.4g} Hz): the joint "
                             "between two points does not integrate the coil's lag",
                             field="shaker.coil_inductance_h")

    def pair_force(self, vals: Mapping[str, float], states: np.ndarray, drive: Drive,
                   basis: ModalBasis) -> np.ndarray:
        """The force on the structure at the drive point (P2, N) at every sample, from the
        two-point model's (n, N, 3) states under the (high-passed) ``drive``."""
        sh, _ = self.shaker(vals)
        x = np.einsum("njk,j->nk", states, self.participations(basis))   # (n, 3): x_d and its rates
        v_hp = drive.fine[::2 * drive.substeps][:x.shape[0]]
        bl, R = sh.force_factor_n_per_a, sh.coil_resistance_ohm
        return (bl * (sh.amplifier_gain_v_per_v * v_hp - bl * x[:, 1]) / R - sh.armature_mass_kg * x[:, 2]
                - sh.suspension_damping_ns_per_m * x[:, 1] - sh.suspension_stiffness_n_per_m * x[:, 0])

    def to_dict(self, vals: Mapping[str, float] | None = None) -> dict[str, Any]:
        d: dict[str, Any] = {"given": {f"shaker.{k}": v for k, v in self.given},
                             "drive_point": self.drive_point, "drive_participation": self.phi_d,
                             "modal_mass_kg": self.modal_mass_kg, "fitted": self.free}
        if vals is not None:
            sh, m_d = self.shaker(vals)
            d["shaker"] = sh.to_dict()
            d["mode1_mass_kg"] = m_d
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> ShakerPath:
        given = tuple(sorted((k.split(".", 1)[1], float(v)) for k, v in d["given"].items()))
        return cls(given, str(d["drive_point"]), float(d["drive_participation"]),
                   None if d.get("modal_mass_kg") is None else float(d["modal_mass_kg"]), d.get("fitted"))

    def describe(self, vals: Mapping[str, float], highpass_hz: float, coil: bool | None,
                 every: bool = False) -> str:
        """The drive path in words (which model of the amplifier and shaker is used; ``coil``
        None: not stated, the parameters being unknown here)."""
        giv = ", ".join(SYMBOLS[k] for k, _ in self.given)
        hp = (f"the amplifier's high-pass at {highpass_hz:.3g} Hz (AC coupling, fitted)" if highpass_hz > 0
              else "no high-pass")
        return (f"voltage -> {hp} -> electrodynamic shaker ({giv} given; "
                f"{self.free or 'nothing'} fitted"
                + ("" if coil is None else f"; coil lag {'integrated' if coil else 'left out'}") + ") "
                f"-> {'every mode' if every else 'mode 1'} at {self.drive_point}")


def _steady(drive: Drive, m: float, k: float, c: float, coil: np.ndarray) -> tuple[float, float, float]:
    """The linear steady state (q, q', i) at the first sample under a sine drive's
    fundamental, the mode driven through ``coil`` = (Bl', R, L, G'): I = (G' V - i w Bl' Q)
    / (R + i w L), (k - m w^2 + i w c) Q = Bl' I (H3, H4; with L = 0 and Bl' the gain,
    R = 1, G' = 1: a drive gain V without back-EMF)."""
    if not drive.frequency_hz:
        return 0.0, 0.0, 0.0
    w = 2 * np.pi * drive.frequency_hz
    bl, R, L, G = coil
    ze = R + 1j * w * L
    emf = bl * bl / ze if L > 0 else 0.0
    q = (bl * G / ze) * drive.phasor / (k - m * w * w + 1j * c * w + 1j * w * emf)
    i = (G * drive.phasor - (1j * w * bl * q if L > 0 else 0.0)) / ze
    return float(q.real), float((1j * w * q).real), float(i.real)


__all__ = ["COIL_NEGLECT", "ShakerPath"]
