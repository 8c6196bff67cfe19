"""Does the force excite what the model needs? Warnings for a simulation-error fit.

A mass-spring oscillator's mass and stiffness are separable only from force at and around
its resonance: below it the response is the stiffness's (x = F / k), above it the mass's
(x = -F / (m w^2)). A fit whose identified resonance lies outside the band holding 90 %
of the force's power has one of them unsupported by the data, however small its error;
the result says so instead of returning numbers that look valid.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from labjoint.signal.excitation import power_band


def resonance_hz(values: dict[str, float]) -> float | None:
    """sqrt(k / m) / (2 pi) of the model's linear part (linear stiffness plus the initial
    stiffness of a Bouc-Wen term), None without a mass or a positive stiffness.

    >>> round(resonance_hz({"inertia.m": 2.0, "linear_stiffness.k": 5e4}), 3)
    25.165
    """
    m = values.get("inertia.m")
    k = values.get("linear_stiffness.k", 0.0) + values.get("bouc_wen.k0", 0.0)
    if not m or m <= 0 or not k > 0:
        return None
    return math.sqrt(k / m) / (2 * math.pi)


def band_warnings(forces: Sequence[np.ndarray], fs: Sequence[float],
                  values: dict[str, float]) -> list[str]:
    """Warnings when the fitted resonance lies outside every record's 90 %-power band."""
    f_n = resonance_hz(values)
    if f_n is None:
        return []
    bands = [power_band(np.asarray(f, float) - np.mean(f), r) for f, r in zip(forces, fs)]
    if any(lo <= f_n <= hi for lo, hi in bands):
        return []
    lo = min(b[0] for b in bands)
    hi = max(b[1] for b in bands)
    which = ("the mass (inertia.m) is barely seen: the force stays below the resonance"
             if f_n > hi else
             "the stiffness is barely seen: the force stays above the resonance")
    return [f"the identified resonance {f_n:.4g} Hz lies outside the band holding 90 % of the "
            f"force's power ({lo:.4g}-{hi:.4g} Hz): {which}; excite across the resonance "
            "before trusting m and k"]
