"""Generator side of the run engine: safety-checked changes, ramps, output, stops.

Every change passes :func:`~labjoint.acquisition.safety.check_settings`; amplitude
changes are ramps at ``limits.ramp_vpp_per_s`` (never steps); while the output is off
the amplitude is parked at the floor, switching on starts from it, switching off ramps
down to it first. An emergency stop switches off at once, without a ramp.
"""

from __future__ import annotations

import logging
import math
import threading

from labjoint.acquisition.safety import check_settings
from labjoint.errors import HardwareError, InputError
from labjoint.hardware.interfaces import GeneratorSettings

log = logging.getLogger(__name__)

#: Lowest amplitude the generator is parked at (AFG1022 into high-Z: 2 mVpp).
FLOOR_VPP = 2e-3


class Abort(Exception):
    """Raised in the engine's thread after an emergency stop."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class DriveMixin:
    """Generator control for :class:`~labjoint.acquisition.engine.RunEngine` (which
    holds the state: ``generator``, ``limits``, ``_gen_lock``, ``_abort``, ``_output``,
    ``_vpp``, ``_target``, ``_readback``...)."""

    def _sync(self) -> None:
        """Adopt the generator's actual state (a plan may start with the output on)."""
        with self._gen_lock:
            s = self.generator.read_settings()
        self._readback, self._output, self._vpp = s, bool(s.output), float(s.amplitude_vpp)
        if s.output:
            self._target = GeneratorSettings(s.frequency_hz, s.amplitude_vpp, s.offset_v)

    def emergency_stop(self, reason: str = "emergency stop") -> None:
        """Output off now (no ramp) and end the running plan with status 'aborted'.

        Safe from any thread or a signal handler; from the engine's own thread (a signal
        handler) it only raises the flag, and the engine switches off at its next step.
        """
        self._abort_reason = reason or "emergency stop"
        self._abort.set()
        if self.torque_gate is not None:
            self.torque_gate.wake()
        if threading.get_ident() == self._thread:
            return
        with self._gen_lock:
            try:
                self.generator.set_output(False)
                self._output = False
            except Exception as exc:
                log.error("emergency stop: switching the output off failed: %s", exc)

    def _need_target(self, what: str) -> GeneratorSettings:
        if self._target is None:
            raise InputError(f"{what} before any Configure: no frequency set", field="frequency_hz")
        return self._target

    def _apply(self, f: float, vpp: float, offset: float) -> None:
        settings = GeneratorSettings(f, vpp, offset, self._output)
        with self._gen_lock:
            self._check_abort()
            check_settings(settings, self.limits)
            try:
                self._readback = self.generator.apply(f, vpp, offset)
            except BaseException:
                self._gen_fault = True
                raise
        self._vpp = vpp
        self._steady = None

    def _switch(self, on: bool) -> None:
        with self._gen_lock:
            if on:
                self._check_abort()
            try:
                self.generator.set_output(on)
            except BaseException:
                self._gen_fault = True
                raise
            self._output = on
        self._steady = None

    def _ramp_to(self, target: float, acquire: bool = True) -> None:
        """Move the amplitude to ``target`` never faster than ``limits.ramp_vpp_per_s``:
        each step is at most the rate times the time since the previous change returned.

        With ``acquire`` and the output on, every step reads ``ramp_step_s`` of samples
        (limits checked; a real DAQ blocks that long, the simulator advances that much
        physics) and sleeps whatever of the step the read did not take.
        """
        t = self._need_target("ramp")
        v, t_prev, stalls = self._vpp, self.clock(), 0
        n_step = max(1, int(round(self.ramp_step_s * self.daq.sample_rate_hz)))
        while v != target:
            t_step = self.clock()
            if acquire and self._output:
                for _ in self._blocks(n_step):
                    pass
            rest = self.ramp_step_s - (self.clock() - t_step)
            if rest > 0:
                self.sleep(rest)
            self._check_abort()
            now = self.clock()
            dv = self.limits.ramp_vpp_per_s * min(now - t_prev, self.ramp_step_s)
            if not dv > 0:
                stalls += 1
                if stalls > 1000:
                    raise HardwareError("ramp stalled: the engine's clock does not advance")
                continue
            v = target if abs(target - v) <= dv else v + math.copysign(dv, target - v)
            self._apply(t.frequency_hz, v, t.offset_v)
            t_prev = self.clock()

    def _configure(self, f: float, vpp: float, offset: float) -> GeneratorSettings | None:
        target = GeneratorSettings(f, vpp, offset)
        check_settings(target, self.limits)
        old, self._target = self._target, target
        if not self._output:
            self._apply(f, self.floor_vpp, offset)
            return self._readback
        if offset != old.offset_v:
            self._target = old
            raise InputError("the offset can only change while the output is off", field="offset_v")
        if f != old.frequency_hz:
            self._apply(f, self._vpp, offset)
        self._ramp_to(vpp)
        return self._readback

    def _output_on(self) -> GeneratorSettings | None:
        t = self._need_target("Output(True)")
        if not self._output:
            self._apply(t.frequency_hz, self.floor_vpp, t.offset_v)
            self._switch(True)
        self._ramp_to(t.amplitude_vpp)
        return self._readback

    def _output_off(self) -> None:
        if self._output and self._target is not None:
            self._ramp_to(self.floor_vpp)
        self._switch(False)
        self._stop_daq()

    def _check_abort(self) -> None:
        if self._abort.is_set():
            raise Abort(self._abort_reason)

    def _shutdown(self, ramp: bool) -> None:
        """DAQ stopped, amplitude ramped down if asked (and possible), output off."""
        try:
            self._stop_daq()
        except Exception as exc:
            log.error("stopping the DAQ failed: %s", exc)
        if ramp and self._output and self._target is not None and not self._abort.is_set():
            try:
                self._ramp_to(self.floor_vpp, acquire=False)
            except Exception as exc:
                log.error("ramping down failed, switching off at once: %s", exc)
        with self._gen_lock:
            try:
                self.generator.set_output(False)
                self._output = False
            except Exception as exc:
                log.error("switching the output off failed: %s", exc)
