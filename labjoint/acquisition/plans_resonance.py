"""Phase-resonance testing: a phase-locked loop on the generator's frequency (issue 30).

At each drive level (Vpp, ascending) the loop sets the frequency so that the response
channel's fundamental is in quadrature with the force's: displacement lags the force
by 90 deg at a mode's phase resonance (velocity in phase, acceleration leads by 90 deg),
waits for steady state and records the run; the backbone and damping follow from drive
and response (:mod:`labjoint.identify.backbone`).

The loop (one update per steady measurement, so the generator's frequency changes at
most once per ``steady_window`` + 2 ``measure_cycles`` cycles, a rate any instrument
allows; every Configure goes through the engine's safety hook,
:func:`labjoint.acquisition.safety.check_settings`: band and Vpp limits):

Steady state is judged on the loop's own quantities: after the engine's WaitSteady
(an amplitude drift below ``steady_tol`` over ``steady_window`` cycles, met while a
lightly damped mode is still settling: its time constant 1 / (zeta w) is 40 cycles at
0.4 %), the phase error and response amplitude are measured again until two consecutive
measurements agree within half the phase tolerance and ``steady_tol`` (at most
``settle_measures`` more); a phase read in the transient biased the slope and the lowest
level's damping 5-10 % on the simulated rig.

    e_n = wrap(phase(response) - phase(force) - target)          (rad)
    f_{n+1} = f_n + g e_n / S_n,   |f_{n+1} - f_n| <= max_step_fraction f_n

Stability: near the resonance the phase error falls linearly with frequency,
e(f) = -S (f - f_r), S = 1 / (zeta f_r) rad/Hz (the mode's phase slope, a linear
single-mode fit); so e_{n+1} = (1 - g S / S_n) e_n. The loop converges iff
0 < g S / S_n < 2, monotonically below 1 and oscillating above. S_n starts at
1 / (``damping_guess`` f_start) and, with ``adapt_slope``, is replaced by the secant
-(e_n - e_{n-1}) / (f_n - f_{n-1}) of the last two steps when that is positive (so the
factor tends to 1 - g; the default g = 0.5 halves the error per update). After lock the
recorded slope is the least-squares line through all of the level's (f, tan e) within
45 deg (:func:`level_slope`), which the analysis uses for the damping at the lowest level;
the pairs themselves go in the metadata (``phase_history``: [f Hz, e rad] per update), from
which the analysis takes the slope's standard error. The step clip
keeps the first steps inside the mode's linear phase range (|e| < ~45 deg).

With ``ringdown_s``, the output is switched off after the last (highest) level and the
free decay recorded for that long (``phase_resonance_ringdown``, metadata ``ringdown``):
the engine ramps the amplitude down at the limits' rate first, so the record starts at
the end of that ramp (a few cycles into the decay).

It cannot lock, and stops with :class:`LockFailed` (the engine then ramps the output
down and switches it off, and names the reason): when the response amplitude is below
``min_response`` (or the force is zero), when the next frequency would leave ``band_hz``
(no resonance in the band), or after ``max_iterations`` updates without lock.

>>> from labjoint.acquisition.messages import Measurement
>>> from labjoint.acquisition.plans import dry_run
>>> msgs = dry_run(phase_resonance([1.0], 30.0, (20.0, 40.0), response_channel="a"),
...                lambda m: Measurement(30.0, {"a": 1.0, "f": 1.0}, {"a": 1.5708, "f": 0.0}, "f")
...                if type(m).__name__ == "Measure" else None)
>>> [type(m).__name__ for m in msgs]
['Configure', 'Output', 'WaitSteady', 'Measure', 'Measure', 'Checkpoint', 'WaitSteady', 'Record', 'Output']
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import Field

from labjoint.acquisition.messages import (Checkpoint, Configure, Measure, Measurement, Output,
                                           Ramp, Record)
from labjoint.acquisition.plan_registry import Cycles, Fraction, Hz, Plan, Vpp, Window, register, tag, wait
from labjoint.errors import InputError, LabjointError

#: phase of the response's fundamental relative to the force's at phase resonance (deg)
TARGET_DEG = {"displacement": -90.0, "velocity": 0.0, "acceleration": 90.0}


class LockFailed(LabjointError):
    """The phase-locked loop could not lock; the message says why and what would help."""


def _wrap(x: float) -> float:
    return (x + math.pi) % (2 * math.pi) - math.pi


def loop_factor(gain: float, slope: float, slope_estimate: float) -> float:
    """Error ratio per update, e_{n+1} / e_n = 1 - g S / S_est (module docstring): the loop
    is stable iff its magnitude is below 1.

    >>> loop_factor(0.5, 10.0, 10.0), loop_factor(0.5, 50.0, 10.0)
    (0.5, -1.5)
    """
    return 1.0 - gain * slope / slope_estimate


def _measure(response: str, force_channel: str | None, target: float, cycles: int):
    """One Measure; (answer, phase error, force channel)."""
    m = yield Measure(cycles)
    if not isinstance(m, Measurement):
        raise TypeError("phase_resonance needs the engine's Measurement answers")
    fch = force_channel or m.reference_force_channel
    if fch is None or fch not in m.amplitude or response not in m.amplitude:
        raise InputError(f"phase_resonance: channels {response!r} and {fch!r} must be "
                         f"measured (have {', '.join(m.amplitude)})", field="response_channel")
    return m, _wrap(m.phase_rad[response] - m.phase_rad[fch] - target), fch


def _settled(response: str, force_channel: str | None, target: float, cycles: int, most: int,
             tol: float, amp_tol: float):
    """Measure until the phase error and the response amplitude stop moving: two
    consecutive measurements within tol / 2 and ``amp_tol`` (at most ``most`` more)."""
    m, e, fch = yield from _measure(response, force_channel, target, cycles)
    for _ in range(most):
        m2, e2, fch = yield from _measure(response, force_channel, target, cycles)
        a, a2 = m.amplitude[response], m2.amplitude[response]
        steady = abs(e2 - e) <= tol / 2 and abs(a2 - a) <= amp_tol * max(abs(a), 1e-300)
        m, e = m2, e2
        if steady:
            break
    return m, e, fch


def level_slope(hist: list[tuple[float, float]]) -> float | None:
    """The mode's phase slope S (rad/Hz) at quadrature from a level's (frequency, phase
    error) pairs within 45 deg of it: minus the least-squares slope of tan(e) against f
    (a single mode's tan(e) = (1 - r^2) / (2 zeta r), r = f / f_r, is nearly a line there,
    where e itself flattens like an arctangent: its secant over +-45 deg reads the slope up
    to 21 % low); None if fewer than two distinct frequencies or a slope of the wrong sign.

    >>> round(level_slope([(29.0, math.atan(0.2)), (29.5, math.atan(0.1)), (30.0, 0.0)]), 6)
    0.2
    """
    pts = [(f, math.tan(e)) for f, e in hist if abs(e) < math.pi / 4]
    if len({f for f, _ in pts}) < 2:
        return None
    fm = sum(f for f, _ in pts) / len(pts)
    em = sum(e for _, e in pts) / len(pts)
    sxx = sum((f - fm) ** 2 for f, _ in pts)
    slope = -sum((f - fm) * (e - em) for f, e in pts) / sxx
    return slope if slope > 0 else None


def _check(*args: Any, **kw: Any) -> None:
    band = kw.get("band_hz", args[2] if len(args) > 2 else None)
    f0 = kw.get("f_start_hz", args[1] if len(args) > 1 else None)
    if band is not None and not band[0] < band[1]:
        raise InputError(f"phase_resonance: band must be (low, high), got {tuple(band)}", field="band_hz")
    if band is not None and f0 is not None and not band[0] <= f0 <= band[1]:
        raise InputError(f"phase_resonance: f_start_hz {f0} is outside band_hz {tuple(band)}",
                         field="f_start_hz")
    levels = kw.get("levels_vpp", args[0] if args else [])
    if list(levels) != sorted(levels) or len(set(levels)) != len(levels):
        raise InputError("phase_resonance: levels must be distinct and ascending (the backbone is "
                         "followed from low to high amplitude)", field="levels_vpp")


@register(check=_check)
def phase_resonance(levels_vpp: Annotated[list[Vpp], Field(min_length=1)], f_start_hz: Hz,
                    band_hz: tuple[Hz, Hz], *, response_channel: str,
                    response_quantity: Literal["displacement", "velocity", "acceleration"] = "acceleration",
                    force_channel: str | None = None,
                    gain: Annotated[float, Field(gt=0, lt=2)] = 0.5, damping_guess: Fraction = 0.01,
                    adapt_slope: bool = True,
                    phase_tol_deg: Annotated[float, Field(gt=0, le=20)] = 1.0,
                    max_iterations: Annotated[int, Field(ge=1)] = 40,
                    max_step_fraction: Fraction = 0.02,
                    min_response: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 0.0,
                    measure_cycles: Cycles = 20, n_cycles: Cycles = 100,
                    steady_max_cycles: Cycles = 400, steady_tol: Fraction = 0.02,
                    steady_window: Window = 10, settle_measures: Annotated[int, Field(ge=0)] = 12,
                    ringdown_s: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = None) -> Plan:
    """Phase resonance at each level of ``levels_vpp`` (module docstring)."""
    target = math.radians(TARGET_DEG[response_quantity])
    tol = math.radians(phase_tol_deg)
    f, lo, hi = float(f_start_hz), float(band_hz[0]), float(band_hz[1])
    slope = 1.0 / (damping_guess * f)                              # rad/Hz
    for i, vpp in enumerate(levels_vpp):
        if i == 0:
            yield Configure(f, vpp)
            yield Output(True)
        else:
            yield Ramp(vpp)
        prev: tuple[float, float] | None = None
        hist: list[tuple[float, float]] = []
        for it in range(max_iterations + 1):
            yield wait(steady_max_cycles, steady_tol, steady_window)
            m, e, fch = yield from _settled(response_channel, force_channel, target, measure_cycles,
                                            settle_measures, tol, steady_tol)
            resp, force = m.amplitude[response_channel], m.amplitude[fch]
            if not resp > min_response or not force > 0:
                raise LockFailed(
                    f"too little response to lock at {vpp:g} Vpp, {f:.6g} Hz: {response_channel} "
                    f"{resp:.3g} (min_response {min_response:g}), force {force:.3g} N. What would help: "
                    "a higher level, a sensor nearer an antinode of the mode, or f_start_hz nearer it")
            hist.append((f, e))
            if adapt_slope and prev is not None and f != prev[0]:
                secant = -(e - prev[1]) / (f - prev[0])
                if secant > 0:
                    slope = secant
            yield Checkpoint(f"phase_resonance level {i + 1}/{len(levels_vpp)} ({vpp:g} Vpp): "
                             f"{f:.6g} Hz, phase error {math.degrees(e):+.2f} deg",
                             {"level": i, "iteration": it, "frequency_hz": f,
                              "phase_error_deg": math.degrees(e)})
            if abs(e) <= tol:
                break
            if it == max_iterations:
                raise LockFailed(
                    f"no lock within {max_iterations} updates at {vpp:g} Vpp: last phase error "
                    f"{math.degrees(e):+.2f} deg at {f:.6g} Hz (tolerance {phase_tol_deg:g} deg). What "
                    "would help: a smaller gain (the loop factor 1 - g S/S_est must stay within "
                    "(-1, 1)), more measure_cycles against noise, or a wider phase_tol_deg")
            step = gain * e / slope
            step = max(-max_step_fraction * f, min(max_step_fraction * f, step))
            prev = (f, e)
            f_next = f + step
            if not lo <= f_next <= hi:
                raise LockFailed(
                    f"no resonance in the band {lo:g}-{hi:g} Hz at {vpp:g} Vpp: the loop reached "
                    f"{f:.6g} Hz with phase error {math.degrees(e):+.2f} deg and would step to "
                    f"{f_next:.6g} Hz. What would help: a band around the mode (its linear natural "
                    "frequency from `labjoint modes`), f_start_hz nearer it")
            f = f_next
            yield Configure(f, vpp)
        measured = level_slope(hist)
        if measured is not None:
            slope = measured
        yield wait(steady_max_cycles, steady_tol, steady_window)
        yield Record(f"phase_resonance_{i:02d}_{tag(vpp)}Vpp", n_cycles=n_cycles,
                     metadata={"plan": "phase_resonance", "plan_step": i, "level_vpp": float(vpp),
                               "response_channel": response_channel, "force_channel": fch,
                               "response_quantity": response_quantity,
                               "phase_error_deg": math.degrees(e), "phase_slope_rad_per_hz": slope,
                               "iterations": it, "locked": True,
                               "phase_slope_measured": measured is not None,
                               "phase_history": [[float(fh), float(eh)] for fh, eh in hist]})
    yield Output(False)
    if ringdown_s is not None:
        yield Record("phase_resonance_ringdown", duration_s=ringdown_s,
                     metadata={"plan": "phase_resonance", "plan_step": len(levels_vpp), "ringdown": True,
                               "from_level_vpp": float(levels_vpp[-1]), "resonance_hz": f,
                               "response_channel": response_channel, "force_channel": fch,
                               "response_quantity": response_quantity})
