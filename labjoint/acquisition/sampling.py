"""DAQ side of the run engine: blocks (emitted into the open run, limit-checked), the
steady-state wait and the fundamental measurement."""

from __future__ import annotations

import logging
import math
from typing import Iterator, Sequence

import numpy as np

from labjoint.documents import Block
from labjoint.acquisition.messages import Measure, Measurement, SteadyResult, WaitSteady
from labjoint.acquisition.online import CycleAmplitudes, fundamental
from labjoint.acquisition.safety import check_block
from labjoint.errors import HardwareError, InputError, LimitExceeded

log = logging.getLogger(__name__)


class SamplingMixin:
    """Acquisition for :class:`~labjoint.acquisition.engine.RunEngine` (which holds
    ``daq``, ``limits``, ``_run``, ``_roles``, ``_steady``... and emits documents)."""

    def _start_daq(self) -> None:
        if not self._daq_running:
            self.daq.start()
            self._daq_running = True

    def _stop_daq(self) -> None:
        if self._daq_running:
            self._daq_running = False
            self._steady = None
            self.daq.stop()

    def _frequency(self) -> float:
        return self._need_target("acquisition").frequency_hz

    def _blocks(self, n_total: int | None) -> Iterator[tuple[int, np.ndarray]]:
        """Read blocks (emitting them into the open run), check limits, then yield them;
        with ``n_total`` None, read until the consumer stops."""
        self._start_daq()
        f, size, done = self._frequency(), self._block(), 0
        relative = self._roles["displacement_channels"]
        while n_total is None or done < n_total:
            n = size if n_total is None else min(size, n_total - done)
            first = self.daq.samples_read
            try:
                volts = self.daq.read(n)
            except HardwareError as exc:
                self._marker("fault", first, {"error": f"{type(exc).__name__}: {exc}"})
                raise
            run = self._run
            if run is not None:
                self._emit("block", Block(run.uid, first - run.start_abs, volts))
                run.n += volts.shape[1]
            try:
                check_block(volts, self.daq.channels, self.limits, f, relative)
            except LimitExceeded as trip:
                self._marker("limit", first + (getattr(trip, "index", 0) or 0),
                             trip.to_dict() if hasattr(trip, "to_dict") else {"reason": str(trip)})
                raise
            self._check_abort()
            done += volts.shape[1]
            yield first, volts

    def _rows(self, names: Sequence[str]) -> list[int]:
        index = {c.name: i for i, c in enumerate(self.daq.channels)}
        return [index[n] for n in names]

    def _wait_steady(self, msg: WaitSteady) -> SteadyResult:
        names = list(self._roles["displacement_channels"])
        if not names:
            raise InputError("WaitSteady needs displacement channels", field="displacement_channels")
        f, fs = self._frequency(), self.daq.sample_rate_hz
        rows = self._rows(names)
        scale = [self.daq.channels[i].units_per_volt(f) for i in rows]
        tracker = CycleAmplitudes(f, fs, np.array(scale))
        reached = False
        blocks = self._blocks(None)
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
        self._steady = result
        return result

    def _measure(self, msg: Measure) -> Measurement:
        f, fs = self._frequency(), self.daq.sample_rate_hz
        parts, first0 = [], None
        for first, volts in self._blocks(int(math.ceil(msg.n_cycles * fs / f))):
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
        return Measurement(f, amp, phase, self._roles["reference_force_channel"], self.limits.max_vpp,
                           peak)
