"""Sensor-phase correction and resolution of the hysteresis loop's energy loss.

A loop's area is the out-of-phase part of force and displacement: for the fundamentals
F_1, U_1 (complex amplitudes), W_1 = pi |F_1| |U_1| sin(phi), phi the phase by which
force leads displacement (seed 002 Eq. 1 with the loop of Fig. 2). A joint that
dissipates little has phi of a few milliradians, so a sensor phase error delta of the
same size changes W by pi |F_1| |U_1| (sin(phi + delta) - sin(phi)) ~ pi K U^2 delta and
can make it negative. Hence:

- correction: the force channel's calibrated phase lead (minus the displacement
  channel's, if it has one), from ``labjoint calibrate``, is applied to each cycle's
  fundamental; W, C and the force phasor are corrected, the higher harmonics (a small
  part of W when the displacement is sinusoidal) are left as measured;
- uncertainty: per cycle u_W^2 = (pi |F_1| |U_1| cos(phi) u_phi)^2 + s_W^2, with u_phi
  the standard uncertainty of the corrected phase (calibration and any stated
  instrument phase match, in quadrature) and s_W the cycle-to-cycle scatter of W over
  the steady cycles (noise, and any real variation); for the mean over n steady
  cycles the phase part is systematic and does not average down:
  u_mean^2 = (pi |F_1| |U_1| cos(phi) u_phi)^2 + s_W^2 / n;
- resolution: 2 u (coverage factor 2, about 95 %); it is at least 2 pi K U^2 u_phi.
  A W below its resolution (a negative one always) is flagged "below resolution"
  and is not a result.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Coverage factor of the resolution (expanded uncertainty, about 95 %).
COVERAGE = 2.0


def correct_phase(per_cycle: dict[str, np.ndarray], delta_rad: float,
                  frequency_hz: float) -> None:
    """Rotate each cycle's force fundamental by ``delta_rad`` and correct W and C for it.

    >>> f1, u1 = np.array([[3e3 * np.exp(0.01j)]]), np.array([[1e-4 + 0j]])
    >>> pc = {"force_harmonics": f1, "displacement_harmonics": u1,
    ...       "energy_loss": np.pi * 3e3 * 1e-4 * np.sin([0.01]),
    ...       "displacement_amplitude": np.array([1e-4])}
    >>> correct_phase(pc, -0.01, 400.0)            # the whole loop was the sensor's phase
    >>> abs(float(pc["energy_loss"][0])) < 1e-12
    True
    """
    if delta_rad == 0.0:
        return
    f1 = per_cycle["force_harmonics"][:, 0]
    prod = f1 * np.conj(per_cycle["displacement_harmonics"][:, 0])
    amp, phi = np.abs(prod), np.angle(prod)
    per_cycle["energy_loss"] = per_cycle["energy_loss"] + np.pi * amp * (
        np.sin(phi + delta_rad) - np.sin(phi))
    per_cycle["force_harmonics"] = per_cycle["force_harmonics"].copy()
    per_cycle["force_harmonics"][:, 0] = f1 * np.exp(1j * delta_rad)
    omega = 2.0 * np.pi * frequency_hz
    w = per_cycle["energy_loss"]
    with np.errstate(divide="ignore", invalid="ignore"):
        per_cycle["damping"] = w / (np.pi * omega * per_cycle["displacement_amplitude"] ** 2)
        if "damping_fundamental" in per_cycle:
            per_cycle["damping_fundamental"] = w / (
                np.pi * omega * np.abs(per_cycle["displacement_harmonics"][:, 0]) ** 2)


def resolution(energy_loss: np.ndarray, force_h1: np.ndarray, displacement_h1: np.ndarray,
               steady: np.ndarray, phase_uncertainty_rad: float
               ) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Per-cycle standard uncertainty of W, per-cycle "below resolution" flags, and the
    summary's uncertainty entries (see module doc)."""
    prod = force_h1 * np.conj(displacement_h1)
    u_phase = np.pi * np.abs(prod) * np.abs(np.cos(np.angle(prod))) * phase_uncertainty_rad
    w_steady = energy_loss[steady]
    n = int(w_steady.size)
    s_w = float(np.std(w_steady, ddof=1)) if n > 1 else 0.0
    u_cycle = np.hypot(u_phase, s_w)
    below = ~(energy_loss >= COVERAGE * u_cycle)                 # NaN counts as below
    u_phase_mean = float(np.mean(u_phase[steady])) if n else float("nan")
    u_mean = float(np.hypot(u_phase_mean, s_w / np.sqrt(n))) if n else float("nan")
    w_mean = float(np.mean(w_steady)) if n else float("nan")
    return u_cycle, below, {
        "energy_loss_j_uncertainty": u_mean,
        "energy_loss_j_resolution": COVERAGE * u_mean,
        "energy_loss_j_uncertainty_phase": u_phase_mean,
        "below_resolution": bool(not w_mean >= COVERAGE * u_mean),
        "cycles_below_resolution": int(below[steady].sum()),
    }


def sensor_phase(force_spec: Any, displacement_specs: list[Any], frequency_hz: float,
                 instrument_deg: float | None = None) -> tuple[float, float, str]:
    """(correction rad, its standard uncertainty rad, a sentence saying what was applied)
    from the channels' calibrated phases at ``frequency_hz`` (``ChannelSpec.phase_at``)
    and a stated instrument phase match ``instrument_deg`` (standard uncertainty).

    The correction is the force sensor's phase lead minus the displacement sensors'
    (their mean, for the difference of two probes).
    """
    inst = float(np.radians(instrument_deg)) if instrument_deg else 0.0
    fp = force_spec.phase_at(frequency_hz) if force_spec is not None else None
    dps = [p for p in (s.phase_at(frequency_hz) for s in displacement_specs) if p is not None]
    d_phase = float(np.mean([p[0] for p in dps])) if dps else 0.0
    d_u = float(np.sqrt(np.mean([p[1] ** 2 for p in dps]))) if dps else 0.0
    parts = []
    if fp is None:
        delta, u = -d_phase, float(np.hypot(d_u, inst))
        parts.append("force sensor phase not calibrated: no force phase correction, and "
                     "the W resolution holds only the cycle-to-cycle scatter"
                     + (" and the stated instrument phase match" if inst else ""))
    else:
        delta = fp[0] - d_phase
        u = float(np.sqrt(fp[1] ** 2 + d_u ** 2 + inst ** 2))
        parts.append(f"force sensor phase from calibration: {np.degrees(fp[0]):+.4f} deg "
                     f"+- {np.degrees(fp[1]):.4f} deg at {frequency_hz:g} Hz")
    if dps:
        parts.append(f"displacement sensor phase {np.degrees(d_phase):+.4f} deg")
    if inst:
        parts.append(f"instrument phase match +- {instrument_deg:g} deg")
    return delta, u, "; ".join(parts) + f"; correction applied {np.degrees(delta):+.4f} deg"
