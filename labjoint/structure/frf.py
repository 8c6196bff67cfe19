"""Nonlinear frequency responses of a structure at constant force (the model side of seed
000's step-sine FRFs): continuation over a band, or solutions at given frequencies.

:func:`response_at` is the building block for comparing with measured constant-force
FRFs: the response phasors per harmonic at every sensor, at the measured frequencies
and force level, solved in the given order (a step sine up or down follows its branch
through a jump as the rig does).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labjoint.structure.assembly import Structure
from labjoint.structure.continuation import Curve, continuation
from labjoint.structure.hbm import REL_TOL, ConvergenceError, HarmonicBalance
from labjoint.structure.reduction import reduced_system
from labjoint.structure.system import NonlinearSystem

DEFAULT_MODES = 10
DEFAULT_HARMONICS = 3


def system_of(structure: Structure, modes: int | None = DEFAULT_MODES) -> NonlinearSystem:
    """The nonlinear system, Craig-Bampton reduced to ``modes`` kept modes (None: unreduced)."""
    if modes is None or not structure.joints:
        return NonlinearSystem.from_structure(structure)
    return reduced_system(structure, modes)[0]


def response_at(structure: Structure | NonlinearSystem, frequencies_hz, force_n,
                harmonics: int = DEFAULT_HARMONICS, modes: int | None = DEFAULT_MODES,
                samples: int | None = None, tol: float = REL_TOL,
                skip_failed: bool = False) -> np.ndarray:
    """(n_freq, H+1, n_sensors) displacement phasors (m) at force amplitude ``force_n`` (N,
    one for all frequencies or one per frequency), solved in the order given, each from
    the previous solution (continuation in frequency, as a step sine follows its branch).

    ``skip_failed``: a frequency where the harmonic balance does not converge (or its
    state or Jacobian overflows) gives NaN phasors instead of raising, and the next frequency starts again from the last
    solution that converged."""
    sysm = structure if isinstance(structure, NonlinearSystem) else system_of(structure, modes)
    hb = HarmonicBalance(sysm, harmonics, samples)
    f = np.asarray(frequencies_hz, float)
    force = np.broadcast_to(np.asarray(force_n, float), f.shape)
    out = np.full((f.size, hb.H + 1, np.atleast_2d(sysm.outputs).shape[0]), np.nan + 0j)
    x = None
    for i, (fi, Fi) in enumerate(zip(f, force)):
        try:
            # with skip_failed, an overflow is a failed point (raised here, not a NaN warning)
            with np.errstate(**({"over": "raise", "invalid": "raise"} if skip_failed else {})):
                x = hb.solve(2 * np.pi * fi, float(Fi), x0=x, tol=tol)
        except (ConvergenceError, FloatingPointError, ValueError, np.linalg.LinAlgError):
            # ValueError: a state or Jacobian that is not finite (scipy's finite check)
            if not skip_failed:
                raise
            continue
        out[i] = hb.phasors(x)
    return out


@dataclass(frozen=True)
class FRF:
    """A constant-force response curve and how it was computed."""

    curve: Curve
    sensor_names: tuple[str, ...]
    modes: int | None

    def to_dict(self) -> dict:
        c = self.curve
        f = c.frequencies_hz
        ph = c.phasors()                                      # (P, H+1, n_s)
        w = 2 * np.pi * f
        acc = -(w ** 2)[:, None] * ph[:, 1, :] / c.force_n    # accelerance, harmonic 1
        sensors = {}
        for i, nm in enumerate(self.sensor_names):
            sensors[nm] = {"accelerance_m_s2_per_n": np.abs(acc[:, i]).tolist(),
                           "phase_deg": np.degrees(np.angle(acc[:, i])).tolist(),
                           "harmonic_amplitudes_m": np.abs(ph[:, :, i]).tolist()}
        return {"force_amplitude_n": c.force_n, "harmonics": c.hbm.H, "samples_per_period": c.hbm.N,
                "reduction": {"method": "craig_bampton", "modes": self.modes} if self.modes is not None
                else {"method": "none"},
                "frequencies_hz": f.tolist(), "points": int(f.size),
                "turning_points_hz": c.turning_points_hz, "branch_direction": c.direction.tolist(),
                "sensors": sensors}


def frf(structure: Structure, force_n: float, band_hz: tuple[float, float],
        harmonics: int = DEFAULT_HARMONICS, modes: int | None = DEFAULT_MODES,
        samples: int | None = None) -> FRF:
    """Continuation over ``band_hz`` at force amplitude ``force_n`` (N, peak)."""
    sysm = system_of(structure, modes)
    hb = HarmonicBalance(sysm, harmonics, samples)
    curve = continuation(hb, force_n, band_hz[0], band_hz[1])
    return FRF(curve, structure.sensor_names, modes if structure.joints else None)
