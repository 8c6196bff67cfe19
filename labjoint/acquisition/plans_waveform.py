"""Broadband plans: a multisine, a swept sine or random noise from the generator's
arbitrary-waveform memory (:mod:`.waveforms`), played for whole periods and recorded.

Each loads its waveform with the output off, switches on (ramped from the floor like a
sine), waits until the per-period RMS of the displacement stops drifting (the transient
has died out), records ``n_periods`` whole periods and switches off. The run's metadata
carries the waveform's description (``excitation``: kind, period, band, lines, crest
factor), which the analysis checks against the signals.

>>> [type(m).__name__ for m in multisine(f_min_hz=50, f_max_hz=200, resolution_hz=5)]
['LoadWaveform', 'Output', 'WaitSteady', 'Record', 'Output']
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from labjoint.acquisition import waveforms as wf
from labjoint.acquisition.messages import LoadWaveform, Output, Record, SetTorque
from labjoint.acquisition.plan_registry import (Cycles, Fraction, Hz, Nm, Plan, Vpp, Window,
                                                register, tag, wait)

Points = Annotated[int, Field(ge=wf.MIN_POINTS, le=wf.MAX_POINTS)]
Seed = Annotated[int, Field(ge=0)]
Seconds = Annotated[float, Field(gt=0, allow_inf_nan=False)]


def play(wave: wf.Waveform, name: str, plan: str, amplitude_vpp: float, n_periods: int,
         torque_nm: float | None, steady_max_periods: int, steady_tol: float,
         steady_window: int) -> Plan:
    """Load ``wave``, switch on, settle, record ``n_periods`` periods as ``name``, switch off."""
    if torque_nm is not None:
        yield SetTorque(torque_nm)
    yield LoadWaveform(tuple(wave.points.tolist()), wave.frequency_hz, amplitude_vpp,
                       wave.band_hz, excitation=wave.describe())
    yield Output(True)
    yield wait(steady_max_periods, steady_tol, steady_window)
    yield Record(name, n_cycles=n_periods, metadata={"plan": plan, "plan_step": 0})
    yield Output(False)


@register()
def multisine(*, f_min_hz: Hz = 50.0, f_max_hz: Hz = 1000.0, resolution_hz: Hz = 5.0,
              lines: Literal["all", "odd", "random_odd"] = "all",
              lines_hz: Annotated[list[Hz], Field(min_length=1)] | None = None,
              phases: Literal["random", "schroeder"] = "random",
              crest_iterations: Annotated[int, Field(ge=0, le=1000)] = 20, seed: Seed = 0,
              amplitude_vpp: Vpp = 1.0, n_periods: Cycles = 10, n_points: Points = wf.MAX_POINTS,
              torque_nm: Nm | None = None, steady_max_periods: Cycles = 20,
              steady_tol: Fraction = 0.02, steady_window: Window = 3) -> Plan:
    """A flat multisine: lines every ``resolution_hz`` in the band (or ``lines_hz``), random
    or Schroeder phases, crest factor lowered by ``crest_iterations``; the period is
    1 / resolution_hz. The waveform is built when the plan is called, so a bad
    parameter is refused then, not when the plan runs."""
    wave = wf.multisine(f_min_hz=f_min_hz, f_max_hz=f_max_hz, resolution_hz=resolution_hz,
                        lines=lines, lines_hz=lines_hz, phases=phases,
                        crest_iterations=crest_iterations, seed=seed, n_points=n_points)
    lo, hi = wave.band_hz
    return play(wave, f"multisine_{tag(lo)}-{tag(hi)}Hz_{tag(amplitude_vpp)}Vpp", "multisine",
                    amplitude_vpp, n_periods, torque_nm, steady_max_periods, steady_tol, steady_window)


@register()
def swept_sine(*, f_start_hz: Hz = 50.0, f_stop_hz: Hz = 1000.0, sweep_s: Seconds = 1.0,
               law: Literal["log", "linear"] = "log", amplitude_vpp: Vpp = 1.0,
               n_periods: Cycles = 1, n_points: Points = wf.MAX_POINTS,
               torque_nm: Nm | None = None, steady_max_periods: Cycles = 6,
               steady_tol: Fraction = 0.02, steady_window: Window = 2) -> Plan:
    """A sine swept from ``f_start_hz`` to ``f_stop_hz`` over ``sweep_s`` (one period),
    repeated; ``n_periods`` sweeps recorded after the transient."""
    wave = wf.swept_sine(f_start_hz=f_start_hz, f_stop_hz=f_stop_hz, period_s=sweep_s, law=law,
                         n_points=n_points)
    return play(wave, f"swept_sine_{tag(f_start_hz)}-{tag(f_stop_hz)}Hz_{tag(amplitude_vpp)}Vpp",
                    "swept_sine", amplitude_vpp, n_periods, torque_nm, steady_max_periods,
                    steady_tol, steady_window)


@register()
def random_noise(*, f_min_hz: Hz = 50.0, f_max_hz: Hz = 1000.0, period_s: Seconds = 1.0,
                 seed: Seed = 0, amplitude_vpp: Vpp = 1.0, n_periods: Cycles = 1,
                 n_points: Points = wf.MAX_POINTS, torque_nm: Nm | None = None,
                 steady_max_periods: Cycles = 6, steady_tol: Fraction = 0.05,
                 steady_window: Window = 2) -> Plan:
    """Band-limited Gaussian noise of one ``period_s`` long realisation; one period recorded
    is a random record, several are periodic noise."""
    wave = wf.random_noise(f_min_hz=f_min_hz, f_max_hz=f_max_hz, period_s=period_s, seed=seed,
                           n_points=n_points)
    return play(wave, f"random_noise_{tag(f_min_hz)}-{tag(f_max_hz)}Hz_{tag(amplitude_vpp)}Vpp",
                    "random_noise", amplitude_vpp, n_periods, torque_nm, steady_max_periods,
                    steady_tol, steady_window)
