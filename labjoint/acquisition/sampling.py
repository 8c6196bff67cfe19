"""DAQ side of the run engine: blocks (emitted into the open run, limit-checked), the
steady-state wait, the fundamental measurement, the drive frequency measured on the
reference channel, and when sample 0 of a run was taken."""

from __future__ import annotations

import logging
import math
from datetime import datetime, timezone
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from labjoint.acquisition.drive import AbortSignal
from labjoint.acquisition.messages import Measure, Measurement, SteadyResult, WaitSteady
from labjoint.acquisition.online import CycleAmplitudes, FrequencyTracker, fundamental
from labjoint.acquisition.safety import check_block
from labjoint.config import LimitsConfig
from labjoint.errors import HardwareError, InputError, LimitExceeded
from labjoint.hardware.interfaces import DAQ

log = logging.getLogger(__name__)


class Sampler:
    """The DAQ side of a run engine: reads blocks (handing each to ``sink``, which puts it
    into the open run), checks them against the limits (``marker`` records where a limit
    tripped or a fault struck), and finds steady state and fundamentals. ``block()`` is
    the block size; ``relative`` the displacement channels (relative limits)."""

    def __init__(self, daq: DAQ, limits: LimitsConfig, abort: AbortSignal, *,
                 block: Callable[[], int], sink: Callable[[int, np.ndarray], None],
                 marker: Callable[[str, int, dict[str, Any]], None]) -> None:
        self.daq, self.limits, self.abort = daq, limits, abort
        self.block, self.sink, self.marker = block, sink, marker
        self.running = False
        self.steady: SteadyResult | None = None
        self.relative: list[str] = []
        self.reference: str | None = None  # the channel the drive frequency is measured on
        self.tracker: FrequencyTracker | None = None

    def forget(self) -> None:
        """The generator changed: a steady state or frequency measured before no longer holds."""
        self.steady, self.tracker = None, None

    def drive_frequency(self) -> dict[str, Any]:
        """The drive frequency on the DAQ's clock, from the reference channel since the last
        generator change (metadata fields; empty until three blocks were seen)."""
        est = self.tracker.estimate() if self.tracker is not None else None
        if est is None:
            return {}
        return {"frequency_measured_hz": est[0], "frequency_measured_uncertainty_hz": est[1],
                "frequency_measured_on": self.reference}

    def _track(self, first: int, volts: np.ndarray, f: float) -> None:
        names = [c.name for c in self.daq.channels]
        if self.reference not in names:
            return
        if self.tracker is None or self.tracker.f0 != f:
            self.tracker = FrequencyTracker(f, self.daq.sample_rate_hz)
        self.tracker.feed(volts[names.index(self.reference)], first)

    def start(self) -> None:
        if not self.running:
            self.daq.start()
            self.running = True

    def stop(self) -> None:
        if self.running:
            self.running = False
            self.forget()  # the sample counter restarts with the next start
            self.daq.stop()

    def blocks(self, n_total: int | None, f: float) -> Iterator[tuple[int, np.ndarray]]:
        """Read blocks (handing them to the sink), check limits, then yield them; with
        ``n_total`` None, read until the consumer stops. ``f``: the drive frequency."""
        self.start()
        size, done = self.block(), 0
        while n_total is None or done < n_total:
            n = size if n_total is None else min(size, n_total - done)
            first = self.daq.samples_read
            try:
                volts = self.daq.read(n)
            except HardwareError as exc:
                self.marker("fault", first, {"error": f"{type(exc).__name__}: {exc}"})
                raise
            self.sink(first, volts)
            try:
                check_block(volts, self.daq.channels, self.limits, f, self.relative)
            except LimitExceeded as trip:
                self.marker("limit", first + (getattr(trip, "index", 0) or 0),
                            trip.to_dict() if hasattr(trip, "to_dict") else {"reason": str(trip)})
                raise
            self._track(first, volts, f)
            self.abort.check()
            done += volts.shape[1]
            yield first, volts

    def consume(self, n: int, f: float) -> None:
        """Read ``n`` samples (checked, handed to the sink) and drop them."""
        for _ in self.blocks(n, f):
            pass

    def _rows(self, names: Sequence[str]) -> list[int]:
        index = {c.name: i for i, c in enumerate(self.daq.channels)}
        return [index[n] for n in names]

    def wait_steady(self, msg: WaitSteady, f: float, per_period_rms: bool = False) -> SteadyResult:
        """Read until the displacement (else acceleration) amplitudes stop drifting (or ``max_cycles``); with
        ``per_period_rms`` (an arbitrary periodic drive, ``f`` its repetition frequency)
        the amplitude of a period is its RMS times sqrt(2), not one line's."""
        names = list(self.relative) or [c.name for c in self.daq.channels if c.quantity == "acceleration"]
        if not names:
            raise InputError("WaitSteady needs displacement or acceleration channels",
                             field="displacement_channels")
        fs = self.daq.sample_rate_hz
        rows = self._rows(names)
        scale = [self.daq.channels[i].units_per_volt(f) for i in rows]
        tracker = CycleAmplitudes(f, fs, np.array(scale), rms=per_period_rms)
        reached = False
        blocks = self.blocks(None, f)
        try:
            for first, volts in blocks:
                tracker.feed(volts[rows], first)
                if tracker.drift(msg.window) <= msg.tol:
                    reached = True
                    break
                if len(tracker.history) >= msg.max_cycles:
                    break
        finally:
            blocks.close()
        last = tracker.history[-1] if tracker.history else np.full(len(names), np.nan)
        result = SteadyResult(reached, len(tracker.history), tracker.drift(msg.window),
                              {n: float(a) for n, a in zip(names, last)})
        if not reached:
            log.warning("steady state not reached in %d cycles (drift %.3g > %.3g)",
                        result.cycles, result.drift, msg.tol)
        self.steady = result
        return result

    def measure(self, msg: Measure, f: float, reference: str | None) -> Measurement:
        """Amplitude, phase and peak (of the input range) of every channel's fundamental."""
        fs = self.daq.sample_rate_hz
        parts, first0 = [], None
        for first, volts in self.blocks(int(math.ceil(msg.n_cycles * fs / f)), f):
            first0 = first if first0 is None else first0
            parts.append(volts)
        volts = np.concatenate(parts, axis=1)
        X = fundamental(volts, fs, f, first_sample=first0)
        peaks = np.max(np.abs(volts), axis=1)
        amp, phase, peak = {}, {}, {}
        for spec, x, p in zip(self.daq.channels, X, peaks):
            s = spec.units_per_volt(f)
            amp[spec.name] = float(abs(x) * abs(s))
            phase[spec.name] = float(np.angle(x * np.sign(s)))
            peak[spec.name] = float(p / spec.range_v)
        return Measurement(f, amp, phase, reference, self.limits.max_vpp, peak)


def run_clock(daq: DAQ) -> dict[str, Any]:
    """When the next run's sample 0 (the DAQ's sample ``samples_read``) was taken: host
    time at the task's start plus its index over the rate (``start_time``, UTC ISO 8601),
    with the stamp's uncertainty; the wall clock now where the DAQ gives no start time or
    its sample clock runs ahead of the wall clock (never a start time in the future).
    ``announced_time`` is when the run was announced (what ``start_time`` used to be)."""
    now = datetime.now(timezone.utc)
    first = int(daq.samples_read)
    t0 = getattr(daq, "started_at", None)
    out: dict[str, Any] = {"start_time": now.isoformat(), "announced_time": now.isoformat(),
                           "first_sample_index": first, "daq_started_at": None,
                           "start_time_uncertainty_s": None}
    if t0 is not None and daq.sample_rate_hz > 0:
        # a sample not yet read cannot have been taken after now: a stamp ahead of the
        # wall clock is a DAQ running faster than real time (the unpaced simulator), whose
        # runs would start in the future, after their own end and out of order with
        # other plans' runs; such a stamp is the wall clock's now
        at = min(t0 + first / float(daq.sample_rate_hz), now.timestamp())
        out.update(start_time=datetime.fromtimestamp(at, timezone.utc).isoformat(),
                   daq_started_at=datetime.fromtimestamp(t0, timezone.utc).isoformat(),
                   start_time_uncertainty_s=getattr(daq, "started_at_uncertainty_s", None))
    return out
