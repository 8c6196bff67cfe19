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
from typing import Any, Callable

import numpy as np

from labjoint.acquisition.safety import check_frequency_step, check_settings
from labjoint.config import LimitsConfig
from labjoint.errors import HardwareError, InputError, LimitExceeded
from labjoint.hardware.interfaces import GeneratorSettings, SignalGenerator

log = logging.getLogger(__name__)

#: Lowest amplitude the generator is parked at (AFG1022 into high-Z: 2 mVpp).
FLOOR_VPP = 2e-3


class Abort(Exception):
    """Raised in the engine's thread after an emergency stop."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class AbortSignal:
    """The emergency-stop flag the engine, its drive and its sampler share."""

    def __init__(self) -> None:
        self._event = threading.Event()
        self.reason = ""

    def set(self, reason: str = "") -> None:
        self.reason = reason or "emergency stop"
        self._event.set()

    def clear(self) -> None:
        self._event.clear()
        self.reason = ""

    def is_set(self) -> bool:
        return self._event.is_set()

    def check(self) -> None:
        """Raise :class:`Abort` if the flag is set."""
        if self._event.is_set():
            raise Abort(self.reason)


class Drive:
    """The generator side of a run engine (module docstring): what it was told (``target``),
    what it reads back (``readback``), whether the output is on and at what amplitude.

    ``acquire(n)`` reads ``n`` samples while a ramp step runs (the sampler's), and
    ``changed()`` is told of every change the generator makes (a steady state found
    before it no longer holds).
    """

    def __init__(self, generator: SignalGenerator, limits: LimitsConfig, abort: AbortSignal, *,
                 acquire: Callable[[int], None], changed: Callable[[], None],
                 sample_rate_hz: Callable[[], float], clock: Callable[[], float],
                 sleep: Callable[[float], None], ramp_step_s: float = 0.05,
                 floor_vpp: float = FLOOR_VPP) -> None:
        self.generator, self.limits, self.abort = generator, limits, abort
        self.acquire, self.changed, self.sample_rate_hz = acquire, changed, sample_rate_hz
        self.clock, self.sleep = clock, sleep
        self.ramp_step_s, self.floor_vpp = ramp_step_s, floor_vpp
        self.lock = threading.RLock()
        self.output = False
        self.vpp = floor_vpp
        self.target: GeneratorSettings | None = None
        self.readback: GeneratorSettings | None = None
        self.fault = False
        #: the loaded arbitrary waveform's band (Hz) and description; None for a sine
        self.band: tuple[float, float] | None = None
        self.excitation: dict[str, Any] | None = None

    def sync(self) -> None:
        """Adopt the generator's actual state (a plan may start with the output on)."""
        self.fault = False
        with self.lock:
            s = self.generator.read_settings()
        self.readback, self.output, self.vpp = s, bool(s.output), float(s.amplitude_vpp)
        if s.output:
            self.target = GeneratorSettings(s.frequency_hz, s.amplitude_vpp, s.offset_v, shape=s.shape)

    def off_now(self, why: str) -> None:
        """Output off at once, no ramp (an emergency stop from another thread)."""
        with self.lock:
            try:
                self.generator.set_output(False)
                self.output = False
            except Exception as exc:
                log.error("%s: switching the output off failed: %s", why, exc)

    def need_target(self, what: str) -> GeneratorSettings:
        if self.target is None:
            raise InputError(f"{what} before any Configure: no frequency set", field="frequency_hz")
        return self.target

    def identify(self) -> str:
        with self.lock:
            return self.generator.identify()

    def _apply(self, f: float, vpp: float, offset: float, amplitude_only: bool = False) -> None:
        """Set the generator (checked against the limits first); ``amplitude_only`` sends
        just the amplitude (ramp steps: no shape, frequency or load re-sent, issue 18).
        The target's shape picks a sine or the loaded arbitrary waveform."""
        shape = self.target.shape if self.target is not None else "sine"
        settings = GeneratorSettings(f, vpp, offset, self.output, shape)
        set_it = self.generator.apply_waveform if shape == "user" else self.generator.apply
        with self.lock:
            self.abort.check()
            check_settings(settings, self.limits, self.band)
            try:
                self.readback = (self.generator.set_amplitude(vpp) if amplitude_only
                                 else set_it(f, vpp, offset))
            except BaseException:
                self.fault = True
                raise
        self.vpp = vpp
        self.changed()

    def _switch(self, on: bool) -> None:
        with self.lock:
            if on:
                self.abort.check()
            try:
                self.generator.set_output(on)
            except BaseException:
                self.fault = True
                raise
            self.output = on
        self.changed()

    def ramp_to(self, target: float, acquire: bool = True) -> None:
        """Move the amplitude to ``target`` never faster than ``limits.ramp_vpp_per_s``:
        each step is at most the rate times the time since the previous change returned.

        With ``acquire`` and the output on, every step reads ``ramp_step_s`` of samples
        (limits checked; a real DAQ blocks that long, the simulator advances that much
        physics) and sleeps whatever of the step the read did not take.
        """
        t = self.need_target("ramp")
        v, t_prev, stalls = self.vpp, self.clock(), 0
        n_step = max(1, int(round(self.ramp_step_s * self.sample_rate_hz())))
        while v != target:
            t_step = self.clock()
            if acquire and self.output:
                self.acquire(n_step)
            rest = self.ramp_step_s - (self.clock() - t_step)
            if rest > 0:
                self.sleep(rest)
            self.abort.check()
            now = self.clock()
            dv = self.limits.ramp_vpp_per_s * min(now - t_prev, self.ramp_step_s)
            if not dv > 0:
                stalls += 1
                if stalls > 1000:
                    raise HardwareError("ramp stalled: the engine's clock does not advance")
                continue
            v = target if abs(target - v) <= dv else v + math.copysign(dv, target - v)
            self._apply(t.frequency_hz, v, t.offset_v, amplitude_only=True)
            t_prev = self.clock()

    def configure(self, f: float, vpp: float, offset: float) -> GeneratorSettings | None:
        """Set frequency, amplitude and offset: parked at the floor while the output is
        off, else the frequency at once and the amplitude by a ramp."""
        target = GeneratorSettings(f, vpp, offset)
        check_settings(target, self.limits)
        if self.output and self.target is not None and self.target.shape != "sine":
            raise InputError("switch the output off before changing from an arbitrary waveform "
                             "to a sine", field="frequency_hz")
        old, self.target = self.target, target
        self.band = self.excitation = None
        if not self.output:
            self._apply(f, self.floor_vpp, offset)
            return self.readback
        if offset != old.offset_v:
            self.target = old
            raise InputError("the offset can only change while the output is off", field="offset_v")
        if f != old.frequency_hz:
            try:
                check_frequency_step(old.frequency_hz, f, self.limits)
            except LimitExceeded:
                self.target = old
                raise
            self._apply(f, self.vpp, offset)
        self.ramp_to(vpp)
        return self.readback

    def ramp(self, vpp: float) -> GeneratorSettings | None:
        """Ramp the amplitude to ``vpp`` at the configured frequency (and shape)."""
        t = self.need_target("Ramp")
        if t.shape != "sine":
            self.target = GeneratorSettings(t.frequency_hz, vpp, t.offset_v, shape=t.shape)
            check_settings(self.target, self.limits, self.band)
            self.ramp_to(vpp)
            return self.readback
        return self.configure(t.frequency_hz, vpp, t.offset_v)

    def load_waveform(self, points: Any, f: float, vpp: float, offset: float,
                      band_hz: tuple[float, float], excitation: dict[str, Any]) -> GeneratorSettings | None:
        """Load an arbitrary waveform (output off) and park it at the floor amplitude; the
        output then ramps up to ``vpp`` as for a sine."""
        if self.output:
            raise InputError("switch the output off before loading a waveform", field="points")
        target = GeneratorSettings(f, vpp, offset, shape="user")
        check_settings(target, self.limits, band_hz)
        with self.lock:
            self.abort.check()
            try:
                self.generator.load_waveform(np.asarray(points, dtype=float))
            except BaseException:
                self.fault = True
                raise
        self.target, self.band, self.excitation = target, tuple(band_hz), dict(excitation)
        self._apply(f, self.floor_vpp, offset)
        return self.readback

    def on(self) -> GeneratorSettings | None:
        """Output on from the floor, then ramped up to the target amplitude."""
        t = self.need_target("Output(True)")
        if not self.output:
            self._apply(t.frequency_hz, self.floor_vpp, t.offset_v)
            self._switch(True)
        self.ramp_to(t.amplitude_vpp)
        return self.readback

    def off(self) -> None:
        """Ramp down to the floor, then output off."""
        if self.output and self.target is not None:
            self.ramp_to(self.floor_vpp)
        self._switch(False)

    def shutdown(self, ramp: bool) -> None:
        """Amplitude ramped down if asked (and possible, without acquiring), output off."""
        if ramp and self.output and self.target is not None and not self.abort.is_set():
            try:
                self.ramp_to(self.floor_vpp, acquire=False)
            except Exception as exc:
                log.error("ramping down failed, switching off at once: %s", exc)
        self.off_now("shutdown")
