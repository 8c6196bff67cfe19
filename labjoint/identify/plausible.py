"""Loops no joint makes, refused by the hysteresis-loop pipeline with what is wrong.

What a file cannot tell: a force sensor of inverted sign on a joint whose stiffness does
not show it (never for a passive joint: the stiffness turns negative with W), a lag
between the channels (W too small or negative: flagged below resolution, see
:mod:`labjoint.identify.resolution`), displacement in millimetres written as metres
while the amplitude stays below a centimetre, or displacement and force swapped when the
force's amplitude is below a centimetre's worth of newtons (then the swapped loop runs
backwards with a positive "stiffness": W < 0 flagged below resolution).
"""

from __future__ import annotations

from typing import Any

from labjoint.errors import InputError
from labjoint.identify.resolution import COVERAGE

#: A joint's relative tangential displacement beyond this amplitude (m) is not one: the
#: column is in other units, or holds the force (displacement and force swapped).
MAX_DISPLACEMENT_AMPLITUDE_M = 0.01


def refuse_impossible(s: dict[str, Any]) -> None:
    """Refuse loops no joint makes: a displacement amplitude of centimetres, or a loop run
    backwards (W < 0 beyond its uncertainty) with a negative stiffness, the signature of a
    force (or displacement) sensor of inverted sign. A negative W with a positive
    stiffness stays a flagged result (``below_resolution``): an uncorrected phase lag
    between the channels gives it too (:mod:`labjoint.identify.resolution`)."""
    u_amp = s["displacement_amplitude_m"]
    if u_amp > MAX_DISPLACEMENT_AMPLITUDE_M:
        raise InputError(f"amplitude {u_amp:.4g} m is not a joint's relative displacement "
                         f"(above {MAX_DISPLACEMENT_AMPLITUDE_M:g} m): the column must be in "
                         "metres (SI), and displacement and force may be swapped",
                         field="displacement")
    w, k = s["energy_loss_j"], s["stiffness_n_per_m"]
    if w < -COVERAGE * s["energy_loss_j_uncertainty"] and k < 0:
        raise InputError(f"runs against the displacement: energy loss {w:.4g} J < 0 (the "
                         f"loop is run backwards; uncertainty {s['energy_loss_j_uncertainty']:.2g}"
                         f" J) with stiffness {k:.4g} N/m < 0: the force sensor's sign (or the "
                         "displacement's) is inverted; force and displacement must be positive "
                         "in the same direction (a passive joint dissipates energy)",
                         field="force")
