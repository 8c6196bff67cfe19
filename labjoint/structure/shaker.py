"""The shaker in the structure model (the shaker itself: :mod:`labjoint.models.shaker`): responses per volt for labs that drive a known
amplifier voltage (issue 15 item 5).

An electrodynamic shaker on a voltage amplifier is an electromechanical element at the
excitation point: the armature (mass m_a, suspension k_s, c_s) carries the coil, whose
current I makes the force Bl I and whose velocity v makes the back-EMF Bl v:

    (R + i w L) I + Bl v = G V                    (coil, amplifier gain G)
    m_a a = Bl I - k_s x - c_s v - F              (armature; F: force into the structure)

With the structure's drive-point accelerance H_d = a / F this gives in closed form

    F / V = (Bl G / Z_e) / (1 + H_d (Z_a + Bl^2 / (i w Z_e))),   Z_e = R + i w L,
    Z_a = m_a + c_s / (i w) - k_s / w^2 (the armature's apparent mass),

and each sensor's response per volt is its accelerance times F / V. Identification
(:func:`identify_shaker`) inverts it: V / F = P (1 + H_d Z_a) + H_d b / (i w) with
P = Z_e / (Bl G), b = Bl / G is linear in (a1, a2, a2 m_a, a1 m_a + a2 c_s,
a1 c_s + a2 k_s + b, a1 k_s) with a1 = R / (Bl G), a2 = L / (Bl G): one linear least
squares over measured F / V and H_d at low level (the structure linear), the amplifier
gain G taken as known (only Bl G and Bl / G are seen by the measurement).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.models.shaker import Shaker, shaker_from_force
from labjoint.models.shaker import force_per_volt as receptance_force_per_volt
from labjoint.structure.assembly import Structure
from labjoint.structure.system import NonlinearSystem


def force_per_volt(shaker: Shaker, frequencies_hz: Any, drive_accelerance: Any) -> np.ndarray:
    """F / V (N per generator volt) on a structure of drive-point accelerance H_d (closed form
    above; :func:`labjoint.models.shaker.force_per_volt` on the receptance -H_d / w^2)."""
    w = 2 * np.pi * np.asarray(frequencies_hz, float)
    return receptance_force_per_volt(shaker, frequencies_hz, -np.asarray(drive_accelerance, complex) / w**2)


def linear_accelerance(structure: Structure, frequencies_hz: Any) -> tuple[np.ndarray, np.ndarray]:
    """The linear structure's (joints stuck) drive-point accelerance (n,) and the sensors' (n, S)."""
    K, M = structure.stiffness(), structure.M
    C = structure.damping_matrix(K)
    hd, hs = [], []
    for f in np.asarray(frequencies_hz, float):
        w = 2 * np.pi * f
        x = np.linalg.solve(K - w**2 * M + 1j * w * C, structure.force)
        hd.append(-(w**2) * structure.force @ x)
        hs.append(-(w**2) * structure.sensors @ x)
    return np.array(hd), np.array(hs)


def per_volt(structure: Structure, shaker: Shaker, frequencies_hz: Any) -> dict[str, np.ndarray]:
    """Force (n,), coil current (n,) and sensor accelerations (n, S) per generator volt of the
    structure with the shaker as a coupled element: the armature DOF merged with the
    excitation point and the coil current an extra unknown, solved directly."""
    f = np.asarray(frequencies_hz, float)
    K, M = structure.stiffness(), structure.M
    C = structure.damping_matrix(K)
    e, n = structure.force, structure.n
    s = shaker
    bl, g = s.force_factor_n_per_a, s.amplifier_gain_v_per_v
    ee = np.outer(e, e)
    out = {"force_per_volt": [], "current_per_volt": [], "acceleration_per_volt": []}
    for w in 2 * np.pi * f:
        A = np.zeros((n + 1, n + 1), complex)
        A[:n, :n] = (K + s.suspension_stiffness_n_per_m * ee - w**2 * (M + s.armature_mass_kg * ee)
                     + 1j * w * (C + s.suspension_damping_ns_per_m * ee))
        A[:n, n] = -bl * e                                  # coil force on the excitation DOF
        A[n, :n] = 1j * w * bl * e                          # back-EMF of the armature velocity
        A[n, n] = s.coil_resistance_ohm + 1j * w * s.coil_inductance_h
        rhs = np.zeros(n + 1, complex)
        rhs[n] = g
        y = np.linalg.solve(A, rhs)
        x, cur = y[:n], y[n]
        a_d = -(w**2) * e @ x
        out["force_per_volt"].append(bl * cur - s.apparent_mass(np.array(w)) * a_d)
        out["current_per_volt"].append(cur)
        out["acceleration_per_volt"].append(-(w**2) * structure.sensors @ x)
    return {k: np.array(v) for k, v in out.items()}


def identify_shaker(frequencies_hz: Any, force_per_volt_measured: Any, drive_accelerance: Any,
                    amplifier_gain_v_per_v: float = 1.0) -> tuple[Shaker, float]:
    """The shaker from a linear test: F / V and the drive-point accelerance a / F at the same
    frequencies (at least 4, spread over the band of interest); returns it and the rms
    relative misfit of V / F."""
    f = np.asarray(frequencies_hz, float)
    fv, h = np.asarray(force_per_volt_measured, complex), np.asarray(drive_accelerance, complex)
    if f.ndim != 1 or f.size < 4 or fv.shape != f.shape or h.shape != f.shape:
        raise InputError("needs at least 4 frequencies with F/V and a/F at each", field="frequencies_hz")
    if not amplifier_gain_v_per_v > 0:
        raise InputError("must be positive", field="amplifier_gain_v_per_v")
    y = 1.0 / fv
    shaker = shaker_from_force(f, fv, h, float(amplifier_gain_v_per_v))
    misfit = np.sqrt(np.mean(np.abs(1.0 / force_per_volt(shaker, f, h) - y) ** 2 / np.abs(y) ** 2))
    return shaker, float(misfit)


def with_shaker(system: NonlinearSystem, shaker: Shaker) -> NonlinearSystem:
    """The (possibly Craig-Bampton reduced) nonlinear system with the shaker coupled in: the
    coil current I is one more unknown (first order: L dI/dt + R I + Bl v_drive = G V), the
    armature adds m_a, c_s, k_s at the drive point, Bl I pushes it; the force input is the
    generator voltage. Outputs: the system's, then ``drive_point`` (m) and ``coil_current`` (A).
    Harmonic balance solves it as any system (``force_n`` is then the voltage amplitude, V)."""
    n, e = system.n, system.force             # the drive displacement is e . x (unit force shape)
    s = shaker
    ee = np.outer(e, e)
    M, C, K = (np.zeros((n + 1, n + 1)) for _ in range(3))
    M[:n, :n] = system.M + s.armature_mass_kg * ee
    C[:n, :n] = system.C + s.suspension_damping_ns_per_m * ee
    C[n, :n] = s.force_factor_n_per_a * e       # back-EMF Bl v
    C[n, n] = s.coil_inductance_h
    K[:n, :n] = system.K + s.suspension_stiffness_n_per_m * ee
    K[:n, n] = -s.force_factor_n_per_a * e      # coil force Bl I on the structure
    K[n, n] = s.coil_resistance_ohm
    force = np.zeros(n + 1)
    force[n] = s.amplifier_gain_v_per_v
    pad = lambda a: np.hstack([np.atleast_2d(a), np.zeros((np.atleast_2d(a).shape[0], 1))])  # noqa: E731
    outputs = np.vstack([pad(system.outputs), np.r_[e, 0.0], np.r_[np.zeros(n), 1.0]])
    return NonlinearSystem(M, C, K, force, pad(system.selectors) if len(system.elements) else
                           np.zeros((0, n + 1)), system.elements, outputs,
                           (*system.output_names, "drive_point", "coil_current"))


def response_per_volt(structure: Structure, shaker: Shaker, frequencies_hz: Any, volts: float,
                      harmonics: int = 3, modes: int | None = 10) -> dict[str, Any]:
    """Nonlinear steady state at generator amplitude ``volts`` (V, peak) by harmonic balance
    on the structure with the shaker (:func:`with_shaker`), per harmonic h = 1..H and per
    volt: the sensors' accelerations (n, S, H), the force into the structure (n, H) and the
    coil current (n, H), solved in the order given (a sweep follows its branch)."""
    from labjoint.structure.frf import response_at, system_of

    if not volts > 0:
        raise InputError(f"must be a positive voltage amplitude, got {volts}", field="volts")
    f = np.asarray(frequencies_hz, float)
    sysm = with_shaker(system_of(structure, modes), shaker)
    ph = response_at(sysm, f, volts, harmonics=harmonics) / volts       # (n, H+1, S+2)
    h = np.arange(1, harmonics + 1)
    w = 2 * np.pi * f[:, None] * h[None, :]                            # (n, H)
    acc = -(w**2)[:, None, :] * np.moveaxis(ph[:, 1:, :-2], 1, 2)       # (n, S, H)
    a_drive = -(w**2) * ph[:, 1:, -2]
    current = ph[:, 1:, -1]
    force = shaker.force_factor_n_per_a * current - shaker.apparent_mass(w) * a_drive
    return {"frequencies_hz": f, "sensors": structure.sensor_names, "acceleration_per_volt": acc,
            "force_per_volt": force, "current_per_volt": current}
