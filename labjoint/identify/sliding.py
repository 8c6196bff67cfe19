"""The stick branches of a loop that slides as a whole (seed 002 Eqs. 4 and 9).

A friction test's loop (macro-slip) is a parallelogram-like loop: after each reversal
the contact sticks and the force follows the shear layer's elastic line, then the joint
slides on a plateau. Its overall least-squares slope averages the plateaus (slope 0) in,
so the shear-layer stiffness K_t of the stick-slip method comes from the stick branches.
"""

from __future__ import annotations

import numpy as np

from labjoint.errors import InputError
from labjoint.identify.friction import _mean_sem, _slip_travel, cycle_labels
from labjoint.identify.identified import Identified

#: A measured loop that makes at least this share of its travel on a sliding plateau
#: (the friction test's own threshold, :func:`labjoint.identify.friction.sliding_force`)
#: slides as a whole: K_t then comes from its stick branches, not its overall slope.
MACRO_SLIP_TRAVEL = 0.25

def slip_travel_fraction(displacement: np.ndarray, force: np.ndarray, sample_rate_hz: float,
                         frequency_hz: float, rate_fraction: float = 0.15) -> float:
    """Share of the displacement travel the loop makes on a sliding plateau (median over
    whole cycles; 0 when the record holds none): the measure :func:`sliding_force` asks
    to be at least 25 % before it calls a loop macro-slip."""
    u = np.asarray(displacement, float)
    f = np.asarray(force, float)
    lab = cycle_labels(u, sample_rate_hz, frequency_hz)
    n = int(lab.max()) + 1
    return _slip_travel(u, f, lab, n, sample_rate_hz, rate_fraction)[0] if n >= 1 else 0.0


def stick_branch_stiffness(displacement: np.ndarray, force: np.ndarray, sample_rate_hz: float,
                           frequency_hz: float, *, source: str = "",
                           swing: float = 0.5) -> Identified:
    """K_t = K_stick / 2 (seed 002 Eqs. 4, 9) from the stick branches of a sliding loop.

    After each reversal of the displacement the whole contact sticks and the force
    moves along the shear layer's elastic line until the joint slides again on the
    opposite plateau. K_stick is the least-squares slope of force on displacement over
    the first ``swing`` of each branch's force swing (reversal to the opposite extreme),
    one intercept per branch; the value is the mean over branches, the uncertainty
    their SEM. On a loop that slides (a Jenkins parallelogram) the loop's
    least-squares slope averages the plateaus (slope 0) with this line and is not the
    shear layer's stiffness.
    """
    u = np.asarray(displacement, float)
    f = np.asarray(force, float)
    half = 0.5 * sample_rate_hz / frequency_hz
    v = np.sign(np.diff(u))
    turns = np.flatnonzero(v[1:] * v[:-1] < 0) + 1
    # reversals at least a third of a half period apart (chatter at the tips removed)
    keep = [] if turns.size == 0 else [int(turns[0])]
    for t in turns[1:]:
        if t - keep[-1] >= half / 3:
            keep.append(int(t))
    slopes = []
    for a, b in zip(keep[:-1], keep[1:]):
        fb, ub = f[a:b + 1], u[a:b + 1]
        far = fb[np.argmax(np.abs(fb - fb[0]))]
        sel = np.abs(fb - fb[0]) <= swing * abs(far - fb[0])
        if sel.sum() < 4:
            continue
        uu, ff = ub[sel] - ub[sel].mean(), fb[sel] - fb[sel].mean()
        den = float(uu @ uu)
        if den > 0:
            slopes.append(float(uu @ ff) / den)
    k = np.asarray(slopes)
    mean, sem = _mean_sem(k / 2)
    if not (np.isfinite(mean) and mean > 0):
        raise InputError(f"the stick branches' slope is not positive ({2 * mean} N/m): check "
                         "force sign/channels", field="force")
    return Identified("shear_stiffness", mean, sem, "N/m", source,
                      "stick-branch slope / 2 (the loop slides)", int(k.size),
                      {"loop_stiffness_n_per_m": 2 * mean})
