"""Admission: a plan is checked against the rig before it is queued, not when it runs.

:func:`check_plan` builds the plan (its own parameter limits, :mod:`.plans`), then runs it
dry against an ideal rig (every wait reaches steady state, every measurement finds the
force the plan asks for on every channel of the rig, and a plan's ``response_channel``
at the phase its loop seeks: a phase-locked loop locks at once) and checks each message as the engine would: generator settings
within the safety limits (:func:`~labjoint.acquisition.safety.check_settings`: amplitude,
frequency range), a closed-loop force target (``force_amplitude_n``) within
``max_force_n`` (:func:`~labjoint.acquisition.safety.check_force_target`), every drive
frequency below the DAQ's Nyquist frequency, every record at most ``limits.max_record_s`` long, no two records of the plan under one name (the second
would be refused by storage mid-plan), and the plan at most ``MAX_MESSAGES`` messages. A
plan that fails is refused with an :class:`~labjoint.errors.InputError` naming the step
and the limit; the engine still checks everything again while it runs (the one safety
hook stays the authority).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from labjoint.acquisition.messages import (Configure, LoadWaveform, Measure, Measurement,
                                           Message, Ramp, Record, SteadyResult, WaitSteady)
from labjoint.acquisition.plans import load_plan
from labjoint.acquisition.plans_resonance import TARGET_DEG
from labjoint.acquisition.safety import LimitTrip, check_force_target, check_settings
from labjoint.config import RigConfig
from labjoint.errors import InputError
from labjoint.hardware.interfaces import GeneratorSettings

MAX_MESSAGES = 100_000
_REF = "reference"


def _ideal(params: Mapping[str, Any], config: RigConfig) -> Any:
    """Answers of a rig that is always steady and delivers the force asked for, on every
    channel of the config; a phase-locked plan finds its response in quadrature at once
    (so its records are checked too, not only its first measurement)."""
    force = float(params.get("force_amplitude_n", 1.0) or 1.0)
    max_vpp = config.limits.max_vpp
    ref = str(params.get("force_channel") or config.rig.reference_force_channel or _REF)
    names = {c.name for c in config.daq.channels} | {ref}
    target = (math.radians(TARGET_DEG.get(str(params.get("response_quantity", "acceleration")),
                                          0.0)) if "response_channel" in params else 0.0)
    amplitude = {n: force for n in names}
    phase = {n: 0.0 if n == ref else target for n in names}
    state = {"f": 1.0}
    names = [c.name for c in config.daq.channels] if config is not None else []
    ref = (config.rig.reference_force_channel if config is not None else None) or _REF
    amp = {n: force for n in [*names, ref, _REF]}
    phase = dict.fromkeys(amp, 0.0)
    resp = params.get("response_channel")
    if isinstance(resp, str) and resp in amp:
        phase[resp] = math.radians(TARGET_DEG.get(str(params.get("response_quantity", "acceleration")), 0.0))

    def respond(msg: Message) -> Any:
        if isinstance(msg, (Configure, LoadWaveform)):
            state["f"] = msg.frequency_hz
        if isinstance(msg, WaitSteady):
            return SteadyResult(True, msg.window, 0.0)
        if isinstance(msg, Measure):
            return Measurement(state["f"], dict(amplitude), dict(phase), ref, max_vpp)
        return None

    return respond


def check_plan(plan: Mapping[str, Any], config: RigConfig) -> None:
    """Refuse ``plan`` (``{"plan": name, **parameters}``) if any step would break a limit
    of the rig in ``config`` (module docstring)."""
    params = {k: v for k, v in dict(plan).items() if k != "plan"}
    limits = config.limits
    nyquist = 0.5 * float(config.daq.sample_rate_hz)
    gen = load_plan(dict(plan))
    for key, value in params.items():       # closed-loop force targets (step_sine)
        if key.endswith("force_amplitude_n") and isinstance(value, (int, float)):
            try:
                check_force_target(value, limits, key)
            except LimitTrip as trip:
                gen.close()
                raise InputError(f"{trip} (the rig's limit)", field=key) from None
    respond = _ideal(params, config)
    f, offset, answer, band = None, 0.0, None, None
    names: dict[str, int] = {}
    try:
        for step in range(MAX_MESSAGES + 1):
            try:
                msg = gen.send(answer)
            except StopIteration:
                return
            if step == MAX_MESSAGES:
                raise InputError(f"the plan has more than {MAX_MESSAGES} steps", field="parameters")
            what = f"step {step + 1} ({type(msg).__name__})"
            if isinstance(msg, (Configure, Ramp, LoadWaveform)):
                if isinstance(msg, (Configure, LoadWaveform)):
                    f, offset = msg.frequency_hz, msg.offset_v
                    vpp = msg.amplitude_vpp
                    band = msg.band_hz if isinstance(msg, LoadWaveform) else None
                else:
                    vpp = msg.to_vpp
                shape = "sine" if band is None else "user"
                try:
                    check_settings(GeneratorSettings(f or 0.0, vpp, offset, shape=shape), limits, band)
                except LimitTrip as trip:
                    raise InputError(f"{what}: {trip} (the rig's limit)", field=_field(trip.limit)) from None
                top = f if band is None else band[1]
                if top is not None and top >= nyquist:
                    raise InputError(f"{what}: frequency {top:g} Hz is at or above the DAQ's Nyquist "
                                     f"frequency {nyquist:g} Hz (sample rate "
                                     f"{config.daq.sample_rate_hz:g} S/s)", field="frequency_hz")
            if isinstance(msg, Record):
                if msg.name in names:
                    raise InputError(f"{what}: a record named {msg.name!r} was already made by "
                                     f"step {names[msg.name]}; run names must be unique",
                                     field="parameters")
                names[msg.name] = step + 1
                seconds = (msg.n_cycles / f if msg.n_cycles is not None and f else msg.duration_s)
                if seconds is not None and not (math.isfinite(seconds) and seconds <= limits.max_record_s):
                    raise InputError(f"{what}: the record would last {seconds:.4g} s, above the rig's "
                                     f"max_record_s = {limits.max_record_s:g} s",
                                     field="n_cycles" if msg.n_cycles is not None else "duration_s")
            answer = respond(msg)
    finally:
        gen.close()


def _field(limit: str) -> str:
    return {"max_vpp": "amplitude_vpp", "min_frequency_hz": "frequency_hz",
            "max_frequency_hz": "frequency_hz"}.get(limit, limit)
