"""The electrodynamic shaker between the amplifier voltage and the structure (issue 29
item 3): one drive component for the record level, the modal model and the structure.

A shaker on a voltage amplifier (gain G) is a coil (resistance R, inductance L, force
factor Bl) on an armature (mass m_a, suspension k_a, c_a) that moves with the structure's
drive point (a stiff stinger, x_a = x_d):

    L di/dt + R i + Bl v_a = G u(t)                                              (S1)
    m_a a_a + c_a v_a + k_a x_a = Bl i - F                                       (S2)

F is the force on the structure. With the structure's drive-point receptance
H_d = X_d / F (m/N) the two give, per generator volt,

    F / U = (Bl G / Z_e) / (1 + H_d (D_a + i w Bl^2 / Z_e)),                     (S3)
    Z_e = R + i w L,   D_a = k_a - w^2 m_a + i w c_a,

and, the shaker known, the force on the structure from the voltage and the drive point's
motion alone (S1 in S2):

    F = (Bl / Z_e) (G U - i w Bl X_d) - D_a X_d                                  (S4)

so every sensor's per-newton FRF is its per-volt FRF divided by F / U (S5). In time,
:func:`force_on_structure` integrates S1 exactly for a piecewise-linear coil drive and
takes S2 at the samples.

The parameters (SI) are the :class:`Shaker` fields; a structure or model file gives them
in a ``[shaker]`` table (:func:`shaker_table`), as many as the user knows:

    [shaker]
    force_factor_n_per_a = 4.0          # Bl
    coil_resistance_ohm = 2.0           # R
    coil_inductance_h = 6.0e-4          # L
    armature_mass_kg = 0.3              # m_a
    suspension_stiffness_n_per_m = 3e3  # k_a
    suspension_damping_ns_per_m = 5.0   # c_a
    amplifier_gain_v_per_v = 1.0        # G (1: the recorded voltage is the amplifier's output)

Which of them a test determines: :mod:`labjoint.models.shaker_fit`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from scipy.signal import lfilter

from labjoint.errors import InputError
from labjoint.tomlfile import read_toml

#: symbol used in messages and docs for each field
SYMBOLS = {"force_factor_n_per_a": "Bl", "coil_resistance_ohm": "R", "coil_inductance_h": "L",
           "armature_mass_kg": "m_a", "suspension_stiffness_n_per_m": "k_a",
           "suspension_damping_ns_per_m": "c_a", "amplifier_gain_v_per_v": "G"}
POSITIVE = ("armature_mass_kg", "coil_resistance_ohm", "force_factor_n_per_a", "amplifier_gain_v_per_v")
ARMATURE = ("armature_mass_kg", "suspension_stiffness_n_per_m", "suspension_damping_ns_per_m")
COIL = ("force_factor_n_per_a", "coil_resistance_ohm", "coil_inductance_h")


@dataclass(frozen=True)
class Shaker:
    """Electrodynamic shaker on a voltage amplifier (SI units; S1, S2)."""

    armature_mass_kg: float
    suspension_stiffness_n_per_m: float
    suspension_damping_ns_per_m: float
    coil_resistance_ohm: float
    coil_inductance_h: float
    force_factor_n_per_a: float
    amplifier_gain_v_per_v: float = 1.0

    def __post_init__(self) -> None:
        for k, v in asdict(self).items():
            if not np.isfinite(v) or v < 0 or (v == 0 and k in POSITIVE):
                raise InputError(f"must be finite and {'positive' if v == 0 else 'non-negative'}, got {v}",
                                 field=f"shaker.{k}")

    def apparent_mass(self, w: np.ndarray) -> np.ndarray:
        """Z_a = m_a + c_a / (i w) - k_a / w^2: armature force per unit acceleration."""
        return self.armature_mass_kg + self.suspension_damping_ns_per_m / (1j * w) - self.suspension_stiffness_n_per_m / w**2

    def armature_stiffness(self, w: np.ndarray) -> np.ndarray:
        """D_a = k_a - w^2 m_a + i w c_a: armature force per unit displacement (S3)."""
        return self.suspension_stiffness_n_per_m - w**2 * self.armature_mass_kg + 1j * w * self.suspension_damping_ns_per_m

    def coil_impedance(self, w: np.ndarray) -> np.ndarray:
        return self.coil_resistance_ohm + 1j * w * self.coil_inductance_h

    def to_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in asdict(self).items()}

    @classmethod
    def from_mapping(cls, d: Mapping[str, Any], where: str = "") -> Shaker:
        """A complete shaker from a mapping of field names (``amplifier_gain_v_per_v``
        defaults to 1); a missing or unknown field is refused by name."""
        vals = checked_values(d, where)
        missing = [f.name for f in fields(cls) if f.name not in vals and f.name != "amplifier_gain_v_per_v"]
        if missing:
            raise InputError(f"shaker parameter {', '.join(missing)} missing", file=where or None,
                             field=f"shaker.{missing[0]}")
        return cls(**vals)


def checked_values(d: Mapping[str, Any], where: str = "") -> dict[str, float]:
    """The known shaker fields of ``d`` as floats; unknown names and non-numbers refused."""
    known = {f.name for f in fields(Shaker)}
    out: dict[str, float] = {}
    for k, v in d.items():
        if k not in known:
            raise InputError(f"unknown shaker parameter; known: {', '.join(sorted(known))}",
                             file=where or None, field=f"shaker.{k}")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or v < 0 \
                or (v == 0 and k in POSITIVE):
            raise InputError(f"must be a finite {'positive' if k in POSITIVE else 'non-negative'} "
                             f"number in SI units, got {v!r}", file=where or None, field=f"shaker.{k}")
        out[k] = float(v)
    return out


def shaker_table(path: str | Path) -> dict[str, float]:
    """The ``[shaker]`` table of a structure or model TOML file: the parameters the user
    gives (any subset), checked; {} when the file has none."""
    d = read_toml(path, InputError, "structure/model file")
    t = d.get("shaker", {})
    if not isinstance(t, dict):
        raise InputError("must be a table ([shaker])", file=str(path), field="shaker")
    return checked_values(t, str(path))


def force_per_volt(shaker: Shaker, frequencies_hz: Any, drive_receptance: Any) -> np.ndarray:
    """F / U (N per generator volt) on a structure of drive-point receptance X_d / F (S3)."""
    w = 2 * np.pi * np.asarray(frequencies_hz, float)
    h = np.asarray(drive_receptance, complex)
    bl, g, ze = shaker.force_factor_n_per_a, shaker.amplifier_gain_v_per_v, shaker.coil_impedance(w)
    return (bl * g / ze) / (1 + h * (shaker.armature_stiffness(w) + 1j * w * bl**2 / ze))


def force_from_motion(shaker: Shaker, frequencies_hz: Any, volts: Any, drive_displacement: Any) -> np.ndarray:
    """The force on the structure (phasor, N) from the voltage and the drive point's
    displacement phasors (S4): a per-newton FRF without a force sensor."""
    w = 2 * np.pi * np.asarray(frequencies_hz, float)
    u, x = np.asarray(volts, complex), np.asarray(drive_displacement, complex)
    bl, g = shaker.force_factor_n_per_a, shaker.amplifier_gain_v_per_v
    return bl / shaker.coil_impedance(w) * (g * u - 1j * w * bl * x) - shaker.armature_stiffness(w) * x


def force_on_structure(shaker: Shaker, volts: Any, fs: float, displacement: Any, velocity: Any,
                       acceleration: Any) -> tuple[np.ndarray, np.ndarray]:
    """(F, i) at the samples from the voltage and the drive point's motion (S1, S2).

    The coil current solves S1 exactly for a drive G u - Bl v that is linear between
    samples (first-order hold), from i = 0 at the first sample; with L = 0 it is
    (G u - Bl v) / R."""
    s = shaker
    u, x, v, a = (np.asarray(z, float) for z in (volts, displacement, velocity, acceleration))
    if not (u.shape == x.shape == v.shape == a.shape and u.ndim == 1):
        raise InputError("voltage and drive-point motion must be 1-D arrays of one length", field="volts")
    e = s.amplifier_gain_v_per_v * u - s.force_factor_n_per_a * v        # coil drive (V)
    R, L = s.coil_resistance_ohm, s.coil_inductance_h
    if L == 0:
        i = e / R
    else:
        tau, h = L / R, 1.0 / fs
        p = np.exp(-h / tau)
        # exact for linear e between samples: i+ = p i + (1-p) e0/R + (e1-e0)/R (1 - tau/h (1-p))
        b0 = (1 - p) - (1 - tau / h * (1 - p))
        b1 = 1 - tau / h * (1 - p)
        x0 = e / R
        i = lfilter([b1, b0], [1.0, -p], x0, zi=[-b1 * x0[0]])[0]
    F = s.force_factor_n_per_a * i - s.armature_mass_kg * a - s.suspension_damping_ns_per_m * v \
        - s.suspension_stiffness_n_per_m * x
    return F, i


def shaker_from_force(f: np.ndarray, fu: np.ndarray, h: np.ndarray, gain: float) -> Shaker:
    """The shaker from F / U and the drive point's accelerance h = a / F (both measured, at
    least 4 frequencies) by one linear least squares:
    U / F = P (1 + H_d D_a) + i w H_d Bl / G with P = Z_e / (Bl G) (S3) is linear in
    (R, L, L m_a, R m_a + L c_a, R c_a + L k_a + Bl^2, R k_a) / (Bl G)."""
    w = 2 * np.pi * f
    iw = 1j * w
    y = 1.0 / fu
    cols = np.stack([np.ones_like(iw), iw, h * iw, h, h / iw, h / iw**2], 1)
    scale = 1.0 / np.abs(y)
    A = np.vstack([(cols * scale[:, None]).real, (cols * scale[:, None]).imag])
    b = np.concatenate([(y * scale).real, (y * scale).imag])
    cn = np.linalg.norm(A, axis=0)
    a1, a2, p1, p0, pm1, pm2 = np.linalg.lstsq(A / cn, b, rcond=None)[0] / cn
    if not (a1 > 0 and a2 > 0):
        raise InputError("the test does not determine the coil (resistance and inductance); "
                         "widen the frequency band", field="frequencies_hz")
    m, k = p1 / a2, pm2 / a1
    c = (p0 - a1 * m) / a2
    bl = (pm1 - a1 * c - a2 * k) * gain
    if not bl > 0 or not m > 0:
        raise InputError(f"the test gives Bl = {bl:.3g} N/A, m_a = {m:.3g} kg: not a shaker; check the "
                         "force's sign and the drive point", field="force")
    return Shaker(float(m), float(max(k, 1e-9)), float(max(c, 1e-9)), float(a1 * bl * gain), float(a2 * bl * gain),
                  float(bl), float(gain))
