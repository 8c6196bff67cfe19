"""The structure's linear damping identified from measured backbones (``linear_damping="measured"``).

A structure file's damping is an assumption (a modal ratio of the joint-free modes, often
a round 0.5 %); a backbone measures the mode's damping down to amplitudes where the
joint sticks, and there the damping is the structure's alone. A model judged with the
file's damping carries that offset at every amplitude, whatever its joint law: on the
simulated rig (0.42 % measured, 0.50 % in the model) it is 10-100 times the ringdown
points' uncertainty, and no joint law can remove it (a law only adds dissipation).

**The linear range** (:func:`linear_range`): the points of every backbone of the mode,
amplitude ascending, from the lowest: a point belongs to it when it agrees with the
uncertainty-weighted mean of the points taken below it within ``SIGMA`` combined
standard uncertainties, in damping ratio and in frequency (a joint that starts to slip
raises the one and lowers the other); the range ends at ``RUN`` disagreeing points in a
row (the slip's onset), a lone disagreeing point is left out (a ringdown's window near
the noise, or another method's small systematic offset); at least ``MIN_POINTS`` points. Its damping zeta_0 is their weighted mean,
with that mean's standard uncertainty. When the range's damping still rises with amplitude
(a weighted line zeta_0 + c A through its points, c beyond ``RISE`` sd: a joint that
micro-slips from the lowest amplitudes, as a continuous Iwan density does, adds damping
~ A^(1+chi) below any detectable onset), zeta_0 is that line's intercept instead (the
points below the onset, outliers off the line left out one at a time): on the simulated
rig's continuous Iwan the mean of the ringdown windows up to 6e-5 m read 0.434 %, the
structure's is 0.420 %.

**The calibration** (:func:`calibrate`): the structure's damping matrix C is scaled by
zeta_0 / zeta_model, zeta_model the model's light-damping ratio of the mode with the
joints stuck (:meth:`labjoint.structure.predict.FrfPredictor.linear_damping_ratio`,
linear in C), so the model's mode has the measured linear damping and the joint law is
judged on what the joint adds. It is one number taken from the data before the
comparison, stated in the notes; the points of the linear range stay in the comparison.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.signal.backbone import Backbone

CHOICES = ("file", "measured")
SIGMA = 3.0
MIN_POINTS = 3
RUN = 3
#: the range's damping rises when its line's slope exceeds this many sd (then extrapolated)
RISE = 2.0
#: an uncertainty is never taken below this fraction of its value (as the backbone kind)
MIN_SD_FRACTION = 1e-6


def linear_range(backbones: Sequence[Backbone]) -> dict[str, Any]:
    """zeta_0, its sd, the points used and the largest amplitude of the linear range
    (module docstring); InputError when fewer than ``MIN_POINTS`` points agree."""
    pts = sorted((p for b in backbones for p in b.points), key=lambda p: p.amplitude)
    top = len(pts)
    for k in range(MIN_POINTS, len(pts) - RUN + 1):
        below = _clipped(pts[:k])
        if below and all(_slips(p, below) for p in pts[k:k + RUN]):
            top = k
            break
    used = _clipped(pts[:top])
    if len(used) < MIN_POINTS:
        raise InputError(f"the measured backbones have no linear range at low amplitude ({len(used)} "
                         f"point(s) agree, {MIN_POINTS} needed) to identify the structure's damping from: "
                         "measure lower amplitudes (a ringdown decays through them), or keep the "
                         "structure file's damping (linear_damping='file')", field="linear_damping")
    z, zsd = _mean(used, "damping_ratio", "damping_sd")
    line = _intercept(pts[:top])
    if line is not None:
        z, zsd, used = line
    return {"zeta": z, "zeta_sd": zsd, "points": len(used), "left_out": top - len(used),
            "extrapolated": line is not None,
            "amplitude_max": float(max(q.amplitude for q in used)),
            "onset_amplitude": float(pts[top].amplitude) if top < len(pts) else None,
            "methods": sorted({q.method for q in used})}


FIELDS = (("damping_ratio", "damping_sd"), ("frequency_hz", "frequency_sd_hz"))


def _mean(pts: Sequence[Any], val: str, sd: str) -> tuple[float, float]:
    v = np.array([getattr(q, val) for q in pts])
    w = 1.0 / np.array([_sd(q, val, sd) for q in pts]) ** 2
    return float(w @ v / w.sum()), float(1.0 / np.sqrt(w.sum()))


def _off(p: Any, pts: Sequence[Any], val: str, sd: str) -> float:
    """p's difference from the points' weighted mean over the combined uncertainty."""
    mean, mean_sd = _mean(pts, val, sd)
    return (getattr(p, val) - mean) / float(np.hypot(_sd(p, val, sd), mean_sd))


def _clipped(pts: Sequence[Any]) -> list[Any]:
    """The points agreeing with their own weighted mean within ``SIGMA`` (damping and
    frequency), the worst left out one at a time."""
    keep = list(pts)
    while len(keep) >= 2:
        worst = max(range(len(keep)), key=lambda i: max(abs(_off(keep[i], keep, v, s)) for v, s in FIELDS))
        if max(abs(_off(keep[worst], keep, v, s)) for v, s in FIELDS) <= SIGMA:
            break
        keep.pop(worst)
    return keep


def _slips(p: Any, below: Sequence[Any]) -> bool:
    """More damped and softer than the range below, each beyond ``SIGMA``, the range's
    mean known better than the point."""
    known = all(_mean(below, v, s)[1] < _sd(p, v, s) for v, s in FIELDS)
    return (known and _off(p, below, "damping_ratio", "damping_sd") > SIGMA
            and _off(p, below, "frequency_hz", "frequency_sd_hz") < -SIGMA)


def _intercept(pts: Sequence[Any]) -> tuple[float, float, list[Any]] | None:
    """zeta at zero amplitude and its sd from a weighted line zeta_0 + c A through the
    points (outliers beyond ``SIGMA`` left out) and the points kept, when their damping rises with amplitude beyond ``RISE`` sd of c (a joint that
    micro-slips from the lowest amplitudes, as a continuous Iwan density does); else None."""
    a = np.array([q.amplitude for q in pts])
    z = np.array([q.damping_ratio for q in pts])
    w = 1.0 / np.array([_sd(q, "damping_ratio", "damping_sd") for q in pts]) ** 2
    keep = np.ones(a.size, bool)
    while keep.sum() >= MIN_POINTS:          # outliers off the line left out one at a time
        X = np.c_[np.ones(keep.sum()), a[keep]]
        cov = np.linalg.inv(X.T @ (X * w[keep, None]))
        b = cov @ (X.T @ (w[keep] * z[keep]))
        r = np.where(keep, np.abs(z - b[0] - b[1] * a) * np.sqrt(w), 0.0)
        if r.max() <= SIGMA:
            break
        keep[int(np.argmax(r))] = False
    else:
        return None
    if not b[1] > RISE * np.sqrt(cov[1, 1]):
        return None
    return float(b[0]), float(np.sqrt(cov[0, 0])), [q for q, k in zip(pts, keep) if k]


def _sd(p: Any, val: str, sd: str) -> float:
    return max(float(getattr(p, sd)), MIN_SD_FRACTION * abs(float(getattr(p, val))), 1e-300)


def calibrate(predictor: Any, backbones: Sequence[Backbone], mode: int = 0) -> tuple[Any, str]:
    """The predictor with its linear damping scaled to the backbones' linear range, and
    the note saying so (module docstring)."""
    lr = linear_range(backbones)
    z_model = predictor.linear_damping_ratio(mode)
    if not z_model > 0:
        raise InputError("the structure has no linear damping to scale (its damping is zero): give it "
                         "a modal or Rayleigh damping", field="linear_damping")
    scale = lr["zeta"] / z_model
    how = ", extrapolated to zero amplitude (its damping rises)" if lr.get("extrapolated") else ""
    note = (f"linear damping of mode {mode + 1} identified from the backbones' linear range "
            f"({lr['points']} points up to {lr['amplitude_max']:.3g} m, {', '.join(lr['methods'])}{how}): "
            f"{lr['zeta']:.5g} +- {lr['zeta_sd']:.2g} where the structure file gives {z_model:.5g}; "
            f"its damping matrix scaled by {scale:.4g}")
    return predictor.with_damping_scale(scale), note
