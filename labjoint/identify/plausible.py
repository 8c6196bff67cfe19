"""Loops no joint makes, and fundamentals the loop cannot resolve, refused by the
hysteresis-loop pipeline with what is wrong.

What a file cannot tell: a force sensor of inverted sign on a record whose true
stiffness is negative (mass-dominated: inverted, it shows k > 0 and W < 0, flagged
below resolution like a channel lag), a lag between the channels (W too small or
negative: flagged below resolution, see :mod:`labjoint.identify.resolution`),
displacement in millimetres written as metres while the amplitude stays below a
centimetre, force in kN written as N, or displacement and force swapped when the force's
amplitude is below 0.01 N (the swapped loop runs backwards with a positive "stiffness":
W < 0, flagged below resolution).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.identify.resolution import COVERAGE

#: Fewer samples per period leave a bias in W above 0.5 % from resampling each cycle
#: (measured on exact records: -0.4 % at 10, -0.9 % at 8, -2.8 % at 6, -5.6 % at 5).
MIN_SAMPLES_PER_PERIOD = 10.0
#: Largest loss of W to the low-pass's gain at the fundamental (zero-phase: |H|^2 per
#: channel, W scales with its square); 0.5 %, as for the resampling bias above.
MAX_FILTER_LOSS = 0.005
#: Largest difference between the frequency used in Eq. 1 and the cycles' own.
MAX_FREQUENCY_MISMATCH = 0.005

#: A joint's relative tangential displacement beyond this amplitude (m) is not one: the
#: column is in other units, or holds the force (displacement and force swapped). A
#: structure's displacement (a cantilever's tip) can be centimetres: every limit here is a
#: default that :class:`Plausibility` overrides.
MAX_DISPLACEMENT_AMPLITUDE_M = 0.01
OVERRIDE = ("override: --max-displacement M, or the rig config's [plausibility] "
            "max_displacement_amplitude_m")
#: Below this amplitude (m) no sensor resolves a displacement (and W / U^2 underflows).
MIN_DISPLACEMENT_AMPLITUDE_M = 1e-15


@dataclass(frozen=True)
class Plausibility:
    """The limits above as values: the rig config's ``[plausibility]`` table (same names,
    lower case) or the CLI's ``--max-displacement M`` override the defaults."""

    max_displacement_amplitude_m: float = MAX_DISPLACEMENT_AMPLITUDE_M
    min_samples_per_period: float = MIN_SAMPLES_PER_PERIOD
    max_filter_loss: float = MAX_FILTER_LOSS
    max_frequency_mismatch: float = MAX_FREQUENCY_MISMATCH

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (np.isfinite(v) and v > 0):
                raise InputError(f"must be a positive number, got {v!r}", field=f"plausibility.{f.name}")

    @classmethod
    def from_mapping(cls, d: Mapping[str, Any] | None, where: str = "") -> Plausibility:
        """From a table of the field names (None values: the default); unknown names refused."""
        known = {f.name for f in fields(cls)}
        d = {k: v for k, v in (d or {}).items() if v is not None}
        bad = sorted(set(d) - known)
        if bad:
            raise InputError(f"unknown plausibility limit; known: {', '.join(sorted(known))}",
                             file=where or None, field=f"plausibility.{bad[0]}")
        return cls(**d)


def limits_from(table: Mapping[str, Any] | None, max_displacement: Any = None, where: str = "",
                field: str = "max_displacement") -> Plausibility | None:
    """The limits of a ``[plausibility]`` table (any of its names) with a displacement cap
    over it (the CLI's ``--max-displacement``, the REST and batch options' ``max_displacement``),
    as every front end takes them; None when neither is given (the defaults)."""
    t = {k: v for k, v in dict(table or {}).items() if v is not None}
    if max_displacement is not None:
        if isinstance(max_displacement, bool) or not isinstance(max_displacement, (int, float)) \
                or not (np.isfinite(max_displacement) and max_displacement > 0):
            raise InputError(f"must be a positive amplitude in m, got {max_displacement!r}", field=field)
        t["max_displacement_amplitude_m"] = float(max_displacement)
    if not t:
        return None
    return Plausibility.from_mapping(t, where)


def _limits(limits: Plausibility | None) -> Plausibility:
    return DEFAULT if limits is None else limits


def refuse_large_displacement(u_amp: float, limits: Plausibility | None = None, where: str = "") -> None:
    """Refuse a displacement amplitude above the cap (m), naming the override."""
    lim = _limits(limits).max_displacement_amplitude_m
    if u_amp > lim:
        raise InputError(f"{where}amplitude {u_amp:.4g} m is not a joint's relative displacement "
                         f"(above {lim:g} m): the column must be in metres (SI), and displacement "
                         f"and force may be swapped; a structure's displacement may be larger "
                         f"({OVERRIDE})", field="displacement")


def refuse_large_record(displacement: Any, limits: Plausibility | None = None, where: str = "") -> None:
    """The same check in one pass over the samples, before any slow analysis: half the
    range between the 0.1 and 99.9 percentiles (a sine's amplitude; spikes ignored)."""
    u = np.asarray(displacement, float)
    u = u[np.isfinite(u)]
    if u.size:
        lo, hi = np.percentile(u, [0.1, 99.9])
        refuse_large_displacement(0.5 * float(hi - lo), limits, where)


def refuse_impossible(s: dict[str, Any], limits: Plausibility | None = None) -> None:
    """Refuse loops no joint makes: a displacement amplitude of centimetres, or a loop run
    backwards (W < 0 beyond its uncertainty) with a negative stiffness, the signature of a
    force (or displacement) sensor of inverted sign. A negative W with a positive
    stiffness stays a flagged result (``below_resolution``): an uncorrected phase lag
    between the channels gives it too (:mod:`labjoint.identify.resolution`)."""
    refuse_far_amplitude(s, limits)
    w, k = s["energy_loss_j"], s["stiffness_n_per_m"]
    if w < -COVERAGE * s["energy_loss_j_uncertainty"] and k < 0:
        raise InputError(f"runs against the displacement: energy loss {w:.4g} J < 0 (the "
                         f"loop is run backwards; uncertainty {s['energy_loss_j_uncertainty']:.2g}"
                         f" J) with stiffness {k:.4g} N/m < 0: the force sensor's sign (or the "
                         "displacement's) is inverted; force and displacement must be positive "
                         "in the same direction (a passive joint dissipates energy)",
                         field="force")


def refuse_far_amplitude(s: dict[str, Any], limits: Plausibility | None = None) -> None:
    """Refuse a displacement amplitude below a femtometre or above the cap (before anything
    squares it: a column in other units can hold 1e295 "m")."""
    u_amp = s["displacement_amplitude_m"]
    if 0 < u_amp < MIN_DISPLACEMENT_AMPLITUDE_M:
        raise InputError(f"amplitude {u_amp:.3g} m is below {MIN_DISPLACEMENT_AMPLITUDE_M:g} m "
                         "(a femtometre): no displacement a sensor resolves; check the "
                         "column's units", field="displacement")
    if not np.isfinite(u_amp):
        raise InputError(f"amplitude {u_amp!r} m is not a number: check the column's units",
                         field="displacement")
    refuse_large_displacement(u_amp, limits)


def refuse_unresolved(f: float, fs: float, cutoff: float | None, order: int,
                      limits: Plausibility | None = None) -> None:
    """Refuse a fundamental the loop cannot resolve: too few samples per period, at or
    near the low-pass cutoff (its gain shrinks W and the amplitudes, not C or k)."""
    lim = _limits(limits)
    if fs / f < lim.min_samples_per_period:
        raise InputError(f"{f:g} Hz leaves {fs / f:.3g} samples per period at fs = {fs:g} Hz; "
                         f"the loop needs at least {lim.min_samples_per_period:g} (below 10, "
                         "resampling each cycle biases W by more than 0.5 %; the rig config's "
                         "[plausibility] min_samples_per_period)", field="frequency_hz")
    if cutoff is None:
        return
    if cutoff <= f:
        raise InputError(f"low-pass cutoff {cutoff:g} Hz would remove the {f:g} Hz "
                         "fundamental: pass a cutoff well above it (or None)", field="cutoff_hz")
    gain = 1.0 / (1.0 + (f / cutoff) ** (2 * order))    # sosfiltfilt: |H|^2
    if 1.0 - gain ** 2 > lim.max_filter_loss:
        raise InputError(f"low-pass cutoff {cutoff:g} Hz (order {order}, zero-phase) passes "
                         f"only {100 * gain:.2f} % of the {f:g} Hz fundamental: W would be "
                         f"{100 * (1 - gain ** 2):.2g} % low; pass a cutoff above "
                         f"{f / (lim.max_filter_loss / 2) ** (1 / (2 * order)):.0f} Hz (labjoint "
                         "analyze --cutoff HZ or --cutoff none; cutoff_hz in Python; it is "
                         "capped at 0.45 fs)", field="cutoff_hz")


def refuse_frequency_mismatch(used: float, measured: float, source: str,
                              limits: Plausibility | None = None) -> None:
    """Refuse when the cycles' own frequency is not the one Eq. 1 would use (C = W /
    (pi omega U^2) would be off by the same fraction)."""
    tol = _limits(limits).max_frequency_mismatch
    if np.isfinite(measured) and abs(measured - used) > tol * used:
        raise InputError(f"{used:g} Hz ({source}) differs from the measured cycle frequency "
                         f"{measured:.6g} Hz by {100 * abs(measured / used - 1):.2g} % (more "
                         f"than {100 * tol:g} %): the damping would be off "
                         "by as much; correct the frequency_hz metadata or leave it out "
                         "(it is then estimated)", field="frequency_hz")


DEFAULT = Plausibility()
