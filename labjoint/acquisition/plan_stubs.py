"""Plan stubs: the small steps plans are made of, each a generator of messages.

Plans combine them with ``yield from`` (bluesky's plan_stubs); like plans they are tested
with no hardware at all:

>>> list(sine_on(400.0, 2.0))
[Configure(frequency_hz=400.0, amplitude_vpp=2.0, offset_v=0.0), Output(on=True)]
>>> [type(m).__name__ for m in settle_and_record("r", 10, {"plan": "dwell"})]
['WaitSteady', 'Record']
"""

from __future__ import annotations

from typing import Any, Generator

from labjoint.acquisition.messages import (Configure, Message, Output, Record, SetTorque,
                                           SteadyResult, WaitSteady)

Stub = Generator[Message, Any, Any]


def sine_on(frequency_hz: float, amplitude_vpp: float, offset_v: float = 0.0) -> Stub:
    """Set the sine, then switch the output on (the engine ramps up from the floor)."""
    yield Configure(frequency_hz, amplitude_vpp, offset_v)
    yield Output(True)


def output_off() -> Stub:
    """Ramp down and switch the output off."""
    yield Output(False)


def torque(torque_nm: float | None) -> Stub:
    """Set the bolt torque (nothing when None)."""
    if torque_nm is not None:
        yield SetTorque(torque_nm)


def settle(max_cycles: int = 400, tol: float = 0.02, window: int = 10
           ) -> Generator[Message, Any, SteadyResult | None]:
    """Wait for steady state; returns the engine's answer."""
    return (yield WaitSteady(max_cycles=max_cycles, tol=tol, window=window))


def settle_and_record(name: str, n_cycles: int, metadata: dict[str, Any], max_cycles: int = 400,
                      tol: float = 0.02, window: int = 10) -> Stub:
    """Wait for steady state, then record ``n_cycles`` as the run ``name``."""
    yield from settle(max_cycles, tol, window)
    return (yield Record(name, n_cycles=n_cycles, metadata=metadata))
