"""Honest verdicts on coarse FRF data (issue 32 item 4).

A candidate that lowers the validation error a lot (to at most ``LARGE_GAIN`` of the
baseline's) without passing the significance test is not evidence that the missing
effect is "not among those tried": on a step sine the test is weak when the resonance is
sampled by a step or two (the half-power band 2 zeta f of a lightly damped mode is a few
tenths of a hertz at 30 Hz), and when the validation set has few phasors. The verdict
then says which and what to measure:

- coarse: near a sweep's peak the steps are wider than a quarter of the half-power
  bandwidth ``2 zeta f_peak`` (zeta the structure's damping of that mode: modal ratio or
  Rayleigh) -> "inconclusive: ... sample the resonance more densely (<= x Hz steps)";
- small validation: fewer than ``MIN_VALIDATION_UNITS`` validation phasors -> "inconclusive:
  the validation set is too small to decide ...".

>>> round(half_power_step(0.005, 28.5), 6)
0.07125
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: a non-significant candidate at or below this share of the baseline's validation NRMSE
LARGE_GAIN = 0.5
#: steps per half-power bandwidth that resolve a resonance
STEPS_PER_BANDWIDTH = 4
MIN_VALIDATION_UNITS = 20


def half_power_step(zeta: float, f_hz: float) -> float:
    """The step (Hz) that puts ``STEPS_PER_BANDWIDTH`` steps in the half-power band."""
    return 2.0 * zeta * f_hz / STEPS_PER_BANDWIDTH


def mode_damping(m: Any) -> float:
    """The structure's damping ratio of the measurement's mode (0 if it has none)."""
    d = m.predictor.structure.damping
    f = float(m.predictor.natural_frequencies(m.mode + 1)[m.mode])
    if d.kind == "modal" and d.ratios:
        return float(d.ratios[min(m.mode, len(d.ratios) - 1)])
    if d.kind == "rayleigh":
        w = 2 * np.pi * f
        return float(d.alpha / (2 * w) + d.beta * w / 2)
    return 0.0


def sampling(m: Any) -> tuple[float, float, float]:
    """(peak frequency, step near the peak, recommended step) of one sweep, Hz."""
    fs = m.frfset
    f = fs.frequencies_hz
    a = np.sum(np.abs(fs.response[:, :, 0]), axis=1) / np.abs(fs.force)
    order = np.argsort(f)
    f, a = f[order], a[order]
    i = int(np.argmax(a))
    if f.size < 2:
        return float(f[i]), float("inf"), float("nan")
    df = float(np.max(np.diff(f)[max(i - 1, 0):i + 1]))
    z = mode_damping(m)
    rec = half_power_step(z, float(f[i])) if z > 0 else df / STEPS_PER_BANDWIDTH
    return float(f[i]), df, rec


def inconclusive(cands: Sequence[Any], base_validation: float, fit_ms: Sequence[Any],
                 val_ms: Sequence[Any]) -> str | None:
    """The verdict when the best candidate gains a lot but is not significant (module
    docstring), else None."""
    weak = [c for c in cands if not c.significant
            and c.nrmse_after_validation <= LARGE_GAIN * base_validation]
    if not weak:
        return None
    c = min(weak, key=lambda c: c.nrmse_after_validation)
    gain = (f"{c.effect} lowers the validation NRMSE {100 * base_validation:.3g} % -> "
            f"{100 * c.nrmse_after_validation:.3g} % but the test is weak ({c.reason})")
    coarse = [(m, *sampling(m)) for m in (*fit_ms, *val_ms)]
    coarse = [t for t in coarse if t[2] > t[3]]
    if coarse:
        m, fpk, df, rec = max(coarse, key=lambda t: t[2] / t[3])
        return (f"inconclusive: {gain}; the resonance is sampled too coarsely ({df:.3g} Hz steps "
                f"near {fpk:.4g} Hz in {m.name}): sample the resonance more densely "
                f"(<= {rec:.2g} Hz steps)")
    n = c.test.n
    if n < MIN_VALIDATION_UNITS:
        return (f"inconclusive: {gain}; the validation set is too small to decide ({n} "
                f"phasors, at least {MIN_VALIDATION_UNITS} needed): measure another force level "
                "or more steps to validate on")
    return None
