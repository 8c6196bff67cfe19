"""The other modes' residual compliance between a response sensor and the drive point
(issue 30), for the ringdown's force removal (:mod:`labjoint.signal.ringdown`,
R -> R / (1 - C_r R)).

With the joints at their stuck (linear) stiffness K and mass-normalised modes phi_k
(K phi_k = w_k^2 M phi_k, the assembled model's generalised eigenproblem; the modal
expansion of the flexibility is the textbook one, not a seed's equation), the static
flexibility between sensor s and drive d is G_sd = s^T K^-1 d = sum_k phi_k,s phi_k,d /
w_k^2; the chosen mode r's own share phi_r,s phi_r,d / w_r^2 taken out leaves

    C_r = s^T K^-1 d - phi_r,s phi_r,d / w_r^2,

every other mode's static share (the README's sum of phi_s phi_d / (w_k^2 - w^2) at w = 0;
at the mode's frequency the modes above r weigh 1 / (1 - w_r^2 / w_k^2) more, on seed
000's pipes 2.6 % for mode 2). The drive point is the structure's ``[excitation]`` and
the sensor one of its ``[[sensors]]``; no armature or other attachment is added.
"""

from __future__ import annotations

import numpy as np

from labjoint.errors import InputError
from labjoint.structure.assembly import Structure
from labjoint.structure.modal import modes


def residual_compliance(structure: Structure, sensor: str, mode: int = 1, *, file: str | None = None) -> float:
    """C_r (m/N) of mode ``mode`` (1-based) between ``sensor`` and the drive point
    (module docstring); an unknown sensor or mode is refused naming it."""
    if sensor not in structure.sensor_names:
        raise InputError(f"no sensor '{sensor}' in the structure (it has {', '.join(structure.sensor_names)})",
                         file=file, field="sensor")
    if not 1 <= mode <= structure.n:
        raise InputError(f"mode {mode} is not among the structure's 1..{structure.n}", file=file, field="mode")
    K = structure.stiffness()
    s = structure.sensors[structure.sensor_names.index(sensor)]
    d = structure.force
    G = float(s @ np.linalg.solve(K, d))
    m = modes(structure, mode, K=K)
    phi = m.shapes[:, mode - 1]
    w2 = (2 * np.pi * m.frequencies_hz[mode - 1]) ** 2
    if not w2 > 0:
        raise InputError(f"mode {mode} has no stiffness (a rigid-body mode)", file=file, field="mode")
    return G - float(s @ phi) * float(d @ phi) / w2
