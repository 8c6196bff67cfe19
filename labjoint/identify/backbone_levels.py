"""Backbones from per-level broadband FRF sets (method ``frf_levels``), distinct from step sine.

A broadband FRF set (:mod:`labjoint.signal.frf_levels`; estimator H1, H2 or Hv) holds
one FRF per drive level (one record each): at each level the joint sees the random or
multisine response of that level, and the FRF is the equivalent linear system there.
Per level:

- **the mode**: ``labjoint modes``' modes of the level (:func:`labjoint.identify.modes.find_modes`:
  LSCF poles stable over model orders, every sensor at once) and the one nearest the
  mode asked for: ``mode_hz``, or else mode ``mode`` (1-based) of the lowest level,
  followed level by level to its nearest mode;
- **frequency and damping**: that mode's LSCF values; their standard uncertainties are
  the spread of the stable poles over the model orders (the interquartile range / 1.349,
  a normal's sd), never below the half-power estimate's difference from LSCF halved
  (the two methods' disagreement: a systematic part the order spread misses);
- **the amplitude at resonance** (m, the fundamental-amplitude measure of the other
  methods): the mode's displacement response at the sensor, taken as a narrow-band
  random response: x_rms^2 = sum_k |H_d(f_k)|^2 P_k over the mode's lines (between
  the neighbouring modes' midpoints), P_k the drive's power per line, the level's drive
  rms squared spread evenly over the level's lines (a flat multisine or white random
  drive, as :mod:`labjoint.acquisition` generates); the amplitude is sqrt(2) x_rms, the
  amplitude of a sine of the same mean-square (a narrow-band response's envelope has
  mean-square 2 x_rms^2). H_d is the FRF as displacement, H / (i w)^p. Its
  uncertainty: the FRF's ``response_std`` propagated through the sum.

A voltage-driven set gives the same amplitude (m/V times V) and the same modes.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.signal.backbone import Backbone, BackbonePoint
from labjoint.signal.frfset import FrfSet

POWER = {"displacement": 0, "velocity": 1, "acceleration": 2}
#: a normal distribution's interquartile range in standard deviations
IQR_PER_SD = 1.349


def is_broadband(s: FrfSet) -> bool:
    return s.estimator != "stepped_sine"


def levels_of(s: FrfSet) -> list[tuple[float, np.ndarray, dict[str, Any]]]:
    """(level, line indices, that level's metadata) per level of a broadband set, ascending:
    one per record when the set names its runs, else per (level, direction)."""
    meta = {m.get("run"): m for m in s.metadata.get("levels", []) if isinstance(m, dict)}
    if s.runs:
        parts = [(np.flatnonzero(np.asarray(s.runs) == r), meta.get(r, {})) for r in dict.fromkeys(s.runs)]
    else:
        parts = [(idx, {}) for _, idx in s.groups()]
    out = [(float(s.level_n[idx[0]]), idx, m) for idx, m in parts]
    return sorted(out, key=lambda t: t[0])


def frf_levels_backbone(s: FrfSet, sensor: str | None = None, *, mode: int = 1,
                        mode_hz: float | None = None, band: tuple[float, float] | None = None) -> Backbone:
    """The backbone of a per-level broadband FRF set (module docstring)."""
    from labjoint.identify.modes import find_modes

    if not is_broadband(s):
        raise InputError("a step-sine set: its backbone is the phase quadrature of each sweep "
                         "(method step_sine)", field="frfset")
    if sensor is not None and sensor not in s.sensors:
        raise InputError(f"no sensor {sensor!r}; sensors: {list(s.sensors)}", field="sensor")
    if isinstance(mode, bool) or not isinstance(mode, int) or mode < 1:
        raise InputError(f"must be a whole number >= 1, got {mode!r}", field="mode")
    j = s.sensors.index(sensor) if sensor else int(np.argmax(np.abs(s.response[:, :, 0]).max(axis=0)))
    p = POWER[s.quantity]
    target = mode_hz
    pts = []
    for level, idx, md in levels_of(s):
        f = s.frequencies_hz[idx]
        h = (s.response[idx, :, 0] / s.force[idx, None]).T                # (sensors, lines)
        b = band or (tuple(md["band_hz"]) if md.get("band_hz") else None)
        try:
            modes = find_modes(f, h, s.quantity, s.sensors, b)
        except InputError as exc:
            raise InputError(f"level {level:g} {s.level_units}: {exc.message}", field="frfset") from None
        if target is None:
            if mode > len(modes):
                raise InputError(f"the lowest level holds {len(modes)} mode(s); mode {mode} asked",
                                 field="mode")
            target = modes[mode - 1]["frequency_hz"]
        k = int(np.argmin([abs(m["frequency_hz"] - target) for m in modes]))
        mo = modes[k]
        fr, z = float(mo["frequency_hz"]), float(mo["damping_ratio"])
        if abs(fr - target) > 0.25 * target:
            found = ", ".join(f"{m['frequency_hz']:.4g}" for m in modes)
            raise InputError(f"level {level:g} {s.level_units}: no mode near {target:.4g} Hz (its modes: "
                             f"{found} Hz)", field="mode")
        target = fr
        lo = 0.5 * (modes[k - 1]["frequency_hz"] + fr) if k > 0 else -np.inf
        hi = 0.5 * (modes[k + 1]["frequency_hz"] + fr) if k + 1 < len(modes) else np.inf
        hp = mo.get("half_power") or {}
        f_sd = max(mo["frequency_spread_hz"] / IQR_PER_SD, 0.5 * abs(fr - (hp.get("frequency_hz") or fr)))
        z_hp = hp.get("damping_ratio")
        z_sd = max(mo["damping_spread"] / IQR_PER_SD, 0.5 * abs(z - z_hp) if z_hp is not None else 0.0)
        amp, amp_sd, lines = _amplitude(s, idx, j, p, lo, hi, md)
        pts.append(BackbonePoint(amp, fr, z, "frf_levels", amp_sd, f_sd, z_sd,
                                 extra={"level": level, "level_units": s.level_units, "lines": lines,
                                        "half_power_frequency_hz": hp.get("frequency_hz"),
                                        "half_power_damping_ratio": z_hp}))
    notes = ("frf_levels: per level the LSCF mode nearest the lowest level's (labjoint modes); "
             "uncertainties the stable poles' spread over model orders (IQR / 1.349), at least half "
             "the half-power estimate's difference",
             "amplitude: sqrt(2) x the rms displacement of the mode's lines at the sensor, the level's "
             "drive rms spread evenly over its lines (a flat broadband drive)")
    return Backbone(pts, "m", "displacement", s.sensors[j], notes)


def _amplitude(s: FrfSet, idx: np.ndarray, j: int, p: int, lo: float, hi: float,
               md: dict[str, Any]) -> tuple[float, float, int]:
    """sqrt(2) x_rms of the lines in (lo, hi) and its sd; the lines used (module docstring)."""
    f = s.frequencies_hz[idx]
    sel = (f > lo) & (f < hi)
    w = 2 * np.pi * f[sel]
    drive_rms = float(md.get("drive_rms") or s.level_n[idx[0]])
    if not (math.isfinite(drive_rms) and drive_rms > 0):
        raise InputError(f"the level's drive rms is {drive_rms!r}: no amplitude at resonance", field="level")
    per_line = drive_rms ** 2 / idx.size
    H = s.response[idx[sel], j, 0] / s.force[idx[sel]] / w ** p                 # |displacement FRF|
    sd = s.response_std[idx[sel], j, 0] / np.abs(s.force[idx[sel]]) / w ** p
    ms = float(np.sum(np.abs(H) ** 2) * per_line)
    ms_sd = float(np.sqrt(np.sum((2 * np.abs(H) * sd) ** 2)) * per_line)
    amp = math.sqrt(2 * ms)
    return amp, 0.5 * amp * ms_sd / ms if ms > 0 else 0.0, int(sel.sum())
