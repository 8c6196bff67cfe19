"""Plans: generators of :mod:`~labjoint.acquisition.messages`, testable without hardware.

Each plan validates its parameters when called (an :class:`~labjoint.errors.InputError`
names the parameter) and yields messages; it never checks the rig's safety limits (the
engine does, in one place). Plans that need feedback (``step_sine``) read the engine's
answers from ``yield``; :func:`dry_run` drives any plan with a stand-in responder.

Conditions come from seed 002 (400 Hz, 1-20 Vpp at 5 Nm: Table 3; 3/5/8 Nm at 400 Hz
20 Vpp: Table 4; friction at 100 Hz, 2 Nm: Eq. 10) and seed 000 (step-sine at constant
force around a resonance, up and down sweeps).

>>> [type(m).__name__ for m in dwell(400, 2, n_cycles=10)]
['Configure', 'Output', 'WaitSteady', 'Record', 'Output']
"""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path
from typing import Annotated, Any, Callable, Generator, Literal, Mapping

import numpy as np
from pydantic import Field, ValidationError, validate_call

from labjoint.acquisition import plan_stubs as stubs
from labjoint.acquisition import plans_resonance  # noqa: F401  (registers phase_resonance)
from labjoint.acquisition import plans_waveform  # noqa: F401  (registers the waveform plans)
from labjoint.acquisition.plan_registry import (PLANS, Cycles, Fraction, Hz, Newton, Nm, Plan,
                                                Volt, Vpp, Window, register, tag, wait)
from labjoint.acquisition.messages import (Configure, Measure, Measurement, Message, Output,
                                           Ramp, Record, SetTorque, WaitSteady)
from labjoint.errors import InputError
from labjoint.tomlfile import read_toml

#: Seed 002 Table 3 excitation levels (Vpp) and Table 4 torques (N*m).
TABLE3_VPP = (1.0, 4.0, 8.0, 12.0, 16.0, 20.0)
TABLE4_NM = (3.0, 5.0, 8.0)
_plan, _tag, _wait = register, tag, wait


# ---- fixed-excitation plans -------------------------------------------------------

@_plan()
def dwell(frequency_hz: Hz, amplitude_vpp: Vpp, *, n_cycles: Cycles = 100,
          torque_nm: Nm | None = None, offset_v: Volt = 0.0, steady_max_cycles: Cycles = 400,
          steady_tol: Fraction = 0.02, steady_window: Window = 10) -> Plan:
    """One steady run: sine on, wait for steady state, record ``n_cycles``, output off."""
    yield from stubs.torque(torque_nm)
    yield from stubs.sine_on(frequency_hz, amplitude_vpp, offset_v)
    yield from stubs.settle_and_record(f"dwell_{_tag(frequency_hz)}Hz_{_tag(amplitude_vpp)}Vpp",
                                       n_cycles, {"plan": "dwell", "plan_step": 0},
                                       steady_max_cycles, steady_tol, steady_window)
    yield from stubs.output_off()


@_plan()
def amplitude_sweep(amplitudes_vpp: Annotated[list[Vpp], Field(min_length=1)] = TABLE3_VPP, *,
                    frequency_hz: Hz = 400.0, torque_nm: Nm = 5.0, n_cycles: Cycles = 100,
                    steady_max_cycles: Cycles = 400, steady_tol: Fraction = 0.02,
                    steady_window: Window = 10) -> Plan:
    """Seed 002 Table 3: one run per excitation level at fixed frequency and torque; the
    output stays on and the amplitude is ramped between levels."""
    yield from stubs.torque(torque_nm)
    yield from stubs.sine_on(frequency_hz, amplitudes_vpp[0])
    for i, vpp in enumerate(amplitudes_vpp):
        if i:
            yield Ramp(vpp)
        yield from stubs.settle_and_record(f"amplitude_sweep_{i:02d}_{_tag(vpp)}Vpp", n_cycles,
                                           {"plan": "amplitude_sweep", "plan_step": i},
                                           steady_max_cycles, steady_tol, steady_window)
    yield from stubs.output_off()


@_plan()
def torque_series(torques_nm: Annotated[list[Nm], Field(min_length=1)] = TABLE4_NM, *,
                  frequency_hz: Hz = 400.0, amplitude_vpp: Vpp = 20.0, n_cycles: Cycles = 100,
                  steady_max_cycles: Cycles = 400, steady_tol: Fraction = 0.02,
                  steady_window: Window = 10) -> Plan:
    """Seed 002 Table 4: one run per bolt torque; output off while the torque changes
    (on a real rig the engine waits there for the operator)."""
    for i, torque in enumerate(torques_nm):
        yield from stubs.torque(torque)
        yield from stubs.sine_on(frequency_hz, amplitude_vpp)
        yield from stubs.settle_and_record(f"torque_series_{i:02d}_{_tag(torque)}Nm", n_cycles,
                                           {"plan": "torque_series", "plan_step": i},
                                           steady_max_cycles, steady_tol, steady_window)
        yield from stubs.output_off()


@_plan()
def friction_test(frequency_hz: Hz = 100.0, torque_nm: Nm = 2.0, amplitude_vpp: Vpp = 20.0, *,
                  n_cycles: Cycles = 100, steady_max_cycles: Cycles = 400,
                  steady_tol: Fraction = 0.02, steady_window: Window = 10) -> Plan:
    """Seed 002 Eq. 10 test: low frequency, low torque, amplitude high enough for
    macro-slip, so the interface slides and mu = f_sld / f_n can be read."""
    yield from stubs.torque(torque_nm)
    yield from stubs.sine_on(frequency_hz, amplitude_vpp)
    yield from stubs.settle_and_record(f"friction_test_{_tag(frequency_hz)}Hz_{_tag(torque_nm)}Nm",
                                       n_cycles, {"plan": "friction_test", "plan_step": 0},
                                       steady_max_cycles, steady_tol, steady_window)
    yield from stubs.output_off()


@_plan()
def sensor_calibration(frequencies_hz: Annotated[list[Hz], Field(min_length=1)] = (
                           200.0, 300.0, 400.0, 500.0, 600.0), *,
                       amplitude_vpp: Vpp = 20.0, torque_nm: Nm = 5.0, n_cycles: Cycles = 100,
                       steady_max_cycles: Cycles = 400, steady_tol: Fraction = 0.02,
                       steady_window: Window = 10, headroom: Fraction = 0.8,
                       measure_cycles: Cycles = 10, max_reductions: Annotated[int, Field(ge=0)] = 4
                       ) -> Plan:
    """Runs for calibrating the nanocomposite sensor against the reference force sensor
    at each frequency (seed 002: 301 N/V at 400 Hz, 20 Vpp, 5 Nm); the calibration itself
    is computed later by ``identify`` from runs tagged ``plan='sensor_calibration'``.

    Every channel must stay inside its input range (a clipped channel cannot be
    calibrated): at each frequency the plan measures each channel's peak and, while one
    exceeds ``headroom`` of its range, lowers the drive in proportion (to 90 % of what
    would just meet the headroom; by half if a channel already clipped), at most
    ``max_reductions`` times. The Vpp used and why are in each run's metadata.
    """
    yield SetTorque(torque_nm)
    for i, f in enumerate(frequencies_hz):
        vpp = float(amplitude_vpp)
        yield Configure(f, vpp)
        if i == 0:
            yield Output(True)
        yield _wait(steady_max_cycles, steady_tol, steady_window)
        vpp, limited_by = yield from _keep_in_range(vpp, headroom, measure_cycles, max_reductions,
                                                    steady_max_cycles, steady_tol, steady_window)
        yield Record(f"sensor_calibration_{i:02d}_{_tag(f)}Hz", n_cycles=n_cycles,
                     metadata={"plan": "sensor_calibration", "plan_step": i,
                               "requested_vpp": float(amplitude_vpp), "range_limited_by": limited_by})
    yield Output(False)


#: A channel this close to its range limit has clipped.
CLIPPED = 0.999


def _keep_in_range(vpp: float, headroom: float, measure_cycles: int, max_reductions: int,
                   steady_max_cycles: int, steady_tol: float, steady_window: int
                   ) -> Generator[Message, Any, tuple[float, list[str]]]:
    """Plan stub: lower Vpp until every channel's peak is within ``headroom`` of its range.

    Returns the Vpp reached and the channels that forced a reduction. A responder that
    does not measure peaks (an old engine, a dry run without answers) leaves Vpp as is.
    """
    limited: list[str] = []
    for _ in range(max_reductions + 1):
        m = yield Measure(measure_cycles)
        peaks = getattr(m, "peak_fraction", None) or {}
        over = {c: p for c, p in peaks.items() if p > headroom}
        if not over:
            break
        limited += [c for c in over if c not in limited]
        worst = max(over.values())
        scale = 0.5 if worst >= CLIPPED else 0.9 * headroom / worst
        vpp *= scale
        yield Ramp(vpp)
        yield _wait(steady_max_cycles, steady_tol, steady_window)
    return vpp, limited


# ---- frequency-stepping plans -----------------------------------------------------

def _check_step_sine(*args: Any, **kw: Any) -> None:
    freqs = kw.get("frequencies_hz", args[0] if args else [])
    if len(set(float(f) for f in freqs)) != len(freqs):
        raise InputError("step_sine: frequencies must be distinct", field="frequencies_hz")


@_plan(check=_check_step_sine)
def step_sine(frequencies_hz: Annotated[list[Hz], Field(min_length=1)],
              force_amplitude_n: Newton, *, initial_vpp: Vpp = 1.0,
              directions: Annotated[list[Literal["up", "down"]], Field(min_length=1)] = ("up", "down"),
              torque_nm: Nm | None = None, force_tol: Fraction = 0.03,
              max_iterations: Annotated[int, Field(ge=0)] = 8,
              max_step_ratio: Annotated[float, Field(gt=1, allow_inf_nan=False)] = 2.0,
              max_vpp: Vpp | None = None, measure_cycles: Cycles = 20, n_cycles: Cycles = 100,
              steady_max_cycles: Cycles = 400, steady_tol: Fraction = 0.02,
              steady_window: Window = 10) -> Plan:
    """Seed 000 step-sine: frequency steps around a resonance at constant force amplitude.

    At each frequency the amplitude on the reference force channel is measured at the
    drive frequency and Vpp is scaled by target/measured (the step ratio clipped to
    ``max_step_ratio``; Vpp saturated at ``max_vpp`` and at the engine's limit) until it
    is within ``force_tol`` or ``max_iterations`` corrections were made; then a steady run
    is recorded. Sweeps run in ``directions`` order ('up' ascending, 'down' descending)
    with the output kept on throughout, so the response stays on its branch and jumps
    show; each step starts from the previous step's Vpp.
    """
    vpp = float(initial_vpp)
    ceiling = math.inf if max_vpp is None else float(max_vpp)
    if torque_nm is not None:
        yield SetTorque(torque_nm)
    step = 0
    for direction in directions:
        for f in sorted(frequencies_hz, reverse=(direction == "down")):
            yield Configure(f, vpp)
            if step == 0:
                yield Output(True)
            corrections = 0
            while True:
                steady = yield _wait(steady_max_cycles, steady_tol, steady_window)
                m = yield Measure(measure_cycles)
                if not isinstance(m, Measurement):
                    raise TypeError("step_sine needs the engine's Measurement answers: run it "
                                    "with RunEngine, or dry_run() with a responder")
                force = m.reference_force_n
                error = abs(force - force_amplitude_n) / force_amplitude_n
                if error <= force_tol or corrections >= max_iterations:
                    break
                ratio = force_amplitude_n / force if force > 0 else max_step_ratio
                ratio = min(max(ratio, 1.0 / max_step_ratio), max_step_ratio)
                new = min(vpp * ratio, ceiling, m.max_vpp)
                if new == vpp:  # saturated at the ceiling: no correction possible
                    break
                vpp = new
                corrections += 1
                yield Ramp(vpp)
            yield Record(f"step_sine_{step:03d}_{direction}_{_tag(f)}Hz", n_cycles=n_cycles,
                         metadata={"plan": "step_sine", "plan_step": step, "direction": direction,
                                   "target_force_n": float(force_amplitude_n),
                                   "measured_force_n": float(force), "force_error": float(error),
                                   "force_converged": bool(error <= force_tol),
                                   "corrections": corrections,
                                   "steady_reached": bool(getattr(steady, "reached", False))})
            step += 1
    yield Output(False)


def broadband_frequencies(f_start_hz: float, f_stop_hz: float, n_frequencies: int,
                          spacing: str = "log") -> list[float]:
    """The stepped-sine frequency grid of :func:`broadband` (log or linear spacing),
    rounded to 6 significant digits.

    >>> broadband_frequencies(100, 400, 3)
    [100.0, 200.0, 400.0]
    """
    grid = (np.geomspace if spacing == "log" else np.linspace)(f_start_hz, f_stop_hz, n_frequencies)
    return [float(f"{f:.6g}") for f in grid]


def _check_broadband(*args: Any, **kw: Any) -> None:
    start, stop = kw.get("f_start_hz", 50.0), kw.get("f_stop_hz", 1000.0)
    if kw.get("frequencies_hz") is None and not stop > start:
        raise InputError(f"broadband: f_stop_hz ({stop}) must exceed f_start_hz ({start})",
                         field="f_stop_hz")


@_plan(check=_check_broadband)
def broadband(*, f_start_hz: Hz = 50.0, f_stop_hz: Hz = 1000.0,
              n_frequencies: Annotated[int, Field(ge=2)] = 30,
              spacing: Literal["log", "linear"] = "log",
              frequencies_hz: Annotated[list[Hz], Field(min_length=1)] | None = None,
              amplitude_vpp: Vpp = 0.5, torque_nm: Nm | None = None, n_cycles: Cycles = 50,
              steady_max_cycles: Cycles = 400, steady_tol: Fraction = 0.02,
              steady_window: Window = 10) -> Plan:
    """Linear FRF at a low, constant excitation level by stepped sine (the generator only
    makes sines): one steady run per frequency, from which
    :func:`labjoint.acquisition.frf.frf_h1` estimates H1 = G_xf / G_ff point by point."""
    freqs = (list(frequencies_hz) if frequencies_hz is not None
             else broadband_frequencies(f_start_hz, f_stop_hz, n_frequencies, spacing))
    if torque_nm is not None:
        yield SetTorque(torque_nm)
    for i, f in enumerate(freqs):
        yield Configure(f, amplitude_vpp)
        if i == 0:
            yield Output(True)
        yield _wait(steady_max_cycles, steady_tol, steady_window)
        yield Record(f"broadband_{i:03d}_{_tag(f)}Hz", n_cycles=n_cycles,
                     metadata={"plan": "broadband", "plan_step": i, "frf": "stepped_sine_h1"})
    yield Output(False)


# ---- loading and previewing -----------------------------------------------------------

def load_plan(source: str | Path | Mapping[str, Any]) -> Plan:
    """A plan from a TOML/JSON file or a mapping: ``plan = "<name>"`` plus its parameters.

    Errors name the file and the field (``plan`` or the parameter).
    """
    where: str | None = None
    if isinstance(source, Mapping):
        data = dict(source)
    else:
        path = Path(source)
        where = str(path)
        data = read_plan_file(path)
    name = data.pop("plan", None)
    if name is None:
        raise InputError("missing the plan name (plan = \"...\")", file=where, field="plan")
    if not isinstance(name, str) or name not in PLANS:
        raise InputError(f"unknown plan {name!r}; known: {sorted(PLANS)}", file=where, field="plan")
    try:
        return PLANS[name](**data)
    except InputError as exc:
        raise InputError(exc.message, file=where, field=exc.field) from None


def read_plan_file(path: Path) -> dict[str, Any]:
    """The mapping in a plan file (.toml or .json); errors name the file and line."""
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise InputError(f"plan files are .toml or .json, got {suffix or 'no suffix'!r}",
                         file=str(path))
    if suffix == ".toml":
        data: Any = read_toml(path, InputError, "plan file")
    else:
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise InputError(f"cannot read plan file: {exc.strerror or exc}",
                             file=str(path)) from None
        try:
            data = json.loads(raw)
        except json.JSONDecodeError as exc:
            raise InputError(f"not valid JSON: {exc.msg}", file=str(path), line=exc.lineno) from None
        except UnicodeDecodeError as exc:
            raise InputError(f"not valid JSON: {exc}", file=str(path)) from None
    if not isinstance(data, dict):
        raise InputError("a plan file holds one table/object", file=str(path))
    return data


def dry_run(plan: Plan, respond: Callable[[Message], Any] | None = None) -> list[Message]:
    """Every message of ``plan``, sending ``respond(msg)`` (default None) back for each."""
    out: list[Message] = []
    answer = None
    while True:
        try:
            msg = plan.send(answer)
        except StopIteration:
            return out
        out.append(msg)
        answer = None if respond is None else respond(msg)

