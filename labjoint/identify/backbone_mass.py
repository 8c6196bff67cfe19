"""The apparent modal mass of phase-resonance levels from a ringdown recorded through the
same force sensor: the mass for which the force-corrected ringdown meets the levels'
frequencies.

Why: the lowest level's phase slope gives zeta_0 = 1 / (S f) and so m_eff only for a
linear mode. A joint that micro-slips from the lowest amplitudes (a continuous Iwan
density) bends the constant-drive phase curve around quadrature: on the simulated rig
the slope's m_eff came out 3.4 % low (3.828 kg where the structure's is 3.962 kg), every
phase-resonance damping 3.4 % high and, through the ringdown's force removal, the
ringdown's frequencies 0.02 Hz high.

The frequency of a phase-resonance level is measured without m_eff (quadrature alone).
The ringdown's force removal (:func:`labjoint.signal.ringdown.remove_force`) gives per
window w_n^2 = w_d^2 + sigma^2 + (Re R + sigma Im R / w_d) / m: exactly linear in 1/m.
Two passes (m_0 and 1.1 m_0) give that line per window; a weighted straight line in
log amplitude through the windows within a factor 1.8 of a level's amplitude gives it at
the level, and m follows from w_n(level) = 2 pi f_level. The shaker's force moves the
frequency by ~2.5 %, so a frequency known to 1e-5 fixes m to ~1e-3 or better. Levels
outside the ringdown's amplitudes are not used; with none inside, the slope's m_eff stays.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from labjoint.signal.backbone import Backbone

#: windows within this factor of a level's amplitude enter its local line
SPAN = 1.8


def _line_at(x: np.ndarray, y: np.ndarray, w: np.ndarray, x0: float) -> tuple[float, float]:
    """Weighted straight line y(x) at x0: (value, standard error from the weights)."""
    W = w.sum()
    xm = float(w @ x) / W
    sxx = float(w @ (x - xm) ** 2)
    ym = float(w @ y) / W
    b = float(w @ ((x - xm) * (y - ym))) / sxx if sxx > 0 else 0.0
    var = 1.0 / W + ((x0 - xm) ** 2 / sxx if sxx > 0 else 0.0)
    return ym + b * (x0 - xm), math.sqrt(var)


def mass_from_ringdown(levels: Backbone, ring: Callable[[float], list[Backbone]],
                       m0: float) -> tuple[float, float, str] | None:
    """(m_eff, its standard uncertainty, a note) from the levels' frequencies and
    ``ring(m)``, the ringdown's force-corrected backbones with mass m; None when no
    level lies within the ringdown's amplitudes (module docstring)."""
    m1 = 1.1 * m0
    r0, r1 = ring(m0), ring(m1)
    pts0 = [p for b in r0 for p in b.points]
    pts1 = [p for b in r1 for p in b.points]
    if len(pts0) != len(pts1) or len(pts0) < 3:
        return None
    A = np.array([p.amplitude for p in pts0])
    w2 = [np.array([(2 * np.pi * p.frequency_hz) ** 2 for p in ps]) for ps in (pts0, pts1)]
    sd = np.array([max(p.frequency_sd_hz, 1e-12) * 2 * (2 * np.pi) ** 2 * p.frequency_hz for p in pts0])
    est = []
    for p in levels.points:
        near = np.abs(np.log(A / p.amplitude)) < math.log(SPAN)
        if not (A.min() <= p.amplitude <= A.max()) or near.sum() < 3:
            continue
        x, wt = np.log(A[near]), 1.0 / sd[near] ** 2
        y0, se = _line_at(x, w2[0][near], wt, math.log(p.amplitude))
        y1, _ = _line_at(x, w2[1][near], wt, math.log(p.amplitude))
        b = (y0 - y1) / (1 / m0 - 1 / m1)
        a = y0 - b / m0
        wp = 2 * np.pi * p.frequency_hz
        shift = wp * wp - a                        # the shaker's force on w_n^2, = b / m
        if not shift * b > 0:
            continue
        m = b / shift
        rel = math.hypot(2 * wp * wp * p.frequency_sd_hz / p.frequency_hz, se) / abs(shift)
        est.append((m, m * rel, p.amplitude))
    if not est:
        return None
    wts = np.array([1 / s ** 2 for _, s, _ in est])
    m = float(np.dot(wts, [e[0] for e in est]) / wts.sum())
    sd = float(1 / math.sqrt(wts.sum()))
    where = ", ".join(f"{a:.2g}" for _, _, a in est)
    note = (f"apparent modal mass {m:.5g} +- {sd:.2g} kg: where the force-corrected ringdown meets the "
            f"phase-resonance frequency at {where} m (the lowest level's phase slope gave {m0:.4g} kg; "
            "a slope is m_eff only for a linear mode)")
    return m, sd, note
