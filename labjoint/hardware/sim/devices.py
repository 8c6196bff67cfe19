"""Simulated instruments: an in-memory function generator and a DAQ reading the simulated rig."""

from __future__ import annotations

import math
import threading
import time
from typing import Any

import numpy as np

from labjoint.errors import BufferOverrun, ConfigError, HardwareError, InputError
from labjoint.hardware.interfaces import DAQ, ChannelSpec, GeneratorSettings, SignalGenerator
from labjoint.hardware.sim.config import SimConfig
from labjoint.hardware.sim.rig import SimRig


class MemoryGenerator(SignalGenerator):
    """A sine generator held in memory (ranges of a Tektronix AFG1022 into high impedance).

    >>> g = MemoryGenerator()
    >>> g.apply(400.0, 20.0).amplitude_vpp
    20.0
    >>> g.read_settings().output
    False
    """

    MAX_FREQUENCY_HZ = 25e6
    MAX_VPP = 20.0
    MAX_LEVEL_V = 10.0
    MIN_POINTS, MAX_POINTS = 2, 8192

    def __init__(self, idn: str = "labjoint,MemoryGenerator,SIM0001,1.0") -> None:
        self._idn = idn
        self._lock = threading.Lock()
        self._settings = GeneratorSettings(frequency_hz=1000.0, amplitude_vpp=1.0, offset_v=0.0, output=False)
        self._closed = False
        self._wave: np.ndarray | None = None

    def identify(self) -> str:
        return self._idn

    def _check_open(self) -> None:
        if self._closed:
            raise HardwareError("generator is closed")

    def apply(self, frequency_hz: float, amplitude_vpp: float, offset_v: float = 0.0) -> GeneratorSettings:
        return self._set(frequency_hz, amplitude_vpp, offset_v, "sine")

    def apply_waveform(self, frequency_hz: float, amplitude_vpp: float,
                       offset_v: float = 0.0) -> GeneratorSettings:
        if self._wave is None:
            raise HardwareError("no arbitrary waveform loaded")
        return self._set(frequency_hz, amplitude_vpp, offset_v, "user")

    def load_waveform(self, points: np.ndarray) -> int:
        x = np.array(points, dtype=float).ravel()
        if not (self.MIN_POINTS <= x.size <= self.MAX_POINTS) or not np.all(np.isfinite(x)):
            raise InputError(f"a waveform has {self.MIN_POINTS}..{self.MAX_POINTS} finite points, "
                             f"got {x.size}", field="points")
        peak = float(np.max(np.abs(x)))
        if peak == 0:
            raise InputError("the waveform is constant zero", field="points")
        with self._lock:
            self._check_open()
            self._wave = x / peak
            self._wave.setflags(write=False)
        return int(x.size)

    def waveform(self) -> np.ndarray | None:
        return self._wave

    def _set(self, frequency_hz: float, amplitude_vpp: float, offset_v: float, shape: str) -> GeneratorSettings:
        f, a, o = float(frequency_hz), float(amplitude_vpp), float(offset_v)
        if not (math.isfinite(f) and 0 < f <= self.MAX_FREQUENCY_HZ):
            raise InputError(f"must be in (0, {self.MAX_FREQUENCY_HZ:g}] Hz, got {frequency_hz!r}", field="frequency_hz")
        if not (math.isfinite(a) and 0 <= a <= self.MAX_VPP):
            raise InputError(f"must be in [0, {self.MAX_VPP:g}] Vpp, got {amplitude_vpp!r}", field="amplitude_vpp")
        if not (math.isfinite(o) and abs(o) + a / 2 <= self.MAX_LEVEL_V):
            raise InputError(f"|offset| + Vpp/2 must not exceed {self.MAX_LEVEL_V:g} V, got offset {offset_v!r}",
                             field="offset_v")
        with self._lock:
            self._check_open()
            self._settings = GeneratorSettings(f, a, o, self._settings.output, shape)
            return self._settings

    def set_amplitude(self, amplitude_vpp: float) -> GeneratorSettings:
        s = self.read_settings()
        return self._set(s.frequency_hz, amplitude_vpp, s.offset_v, s.shape)

    def set_output(self, on: bool) -> None:
        with self._lock:
            self._check_open()
            s = self._settings
            self._settings = GeneratorSettings(s.frequency_hz, s.amplitude_vpp, s.offset_v, bool(on), s.shape)

    def read_settings(self) -> GeneratorSettings:
        with self._lock:
            self._check_open()
            return self._settings

    def close(self) -> None:
        with self._lock:
            if not self._closed:
                s = self._settings
                self._settings = GeneratorSettings(s.frequency_hz, s.amplitude_vpp, s.offset_v, False, s.shape)
            self._closed = True


class SimDAQ(DAQ):
    """A DAQ whose samples come from :class:`SimRig`; each read asks the generator for its settings.

    ``realtime=True`` paces reads to the sample clock (as a real module would block).
    """

    def __init__(self, rig: Any, generator: SignalGenerator, realtime: bool = False) -> None:
        self.rig = rig
        self.generator = generator
        self.realtime = realtime
        self._running = False
        self._overrun_at: int | None = None
        self._faulted = False
        self._count = 0
        self._t0 = 0.0
        self._closed = False

    def configure(self, channels: list[ChannelSpec], sample_rate_hz: float) -> float:
        if self._running:
            raise HardwareError("stop the acquisition before reconfiguring")
        return self.rig.configure(list(channels), sample_rate_hz)

    @property
    def channels(self) -> list[ChannelSpec]:
        return self.rig.channels

    @property
    def sample_rate_hz(self) -> float:
        return self.rig.sample_rate_hz

    def start(self) -> None:
        if self._closed:
            raise HardwareError("DAQ is closed")
        self._running = True
        self._faulted = False
        self._count = 0
        self._t0 = time.monotonic()
        self.started_at, self.started_at_uncertainty_s = time.time(), 0.0

    def inject_overrun(self, at_sample: int) -> None:
        """Fault injection: the read that reaches sample ``at_sample`` (counted from start) overruns."""
        if at_sample < 0:
            raise InputError("must be >= 0", field="at_sample")
        self._overrun_at = int(at_sample)

    def read(self, n_samples: int, out: np.ndarray | None = None) -> np.ndarray:
        n = int(n_samples)
        if n <= 0:
            raise InputError(f"must be positive, got {n_samples!r}", field="n_samples")
        if not self._running:
            raise HardwareError("read() before start()")
        if self._faulted:
            raise BufferOverrun("acquisition stopped by an earlier buffer overrun; restart the task")
        if self._overrun_at is not None and self._count + n > self._overrun_at:
            self._overrun_at = None
            self._faulted = True
            raise BufferOverrun(f"DAQ buffer overrun at sample {self._count + n}: samples were lost")
        if out is not None and out.shape != (len(self.channels), n):
            raise InputError(f"out must have shape {(len(self.channels), n)}, got {out.shape}", field="out")
        settings = self.generator.read_settings()
        wave = self.generator.waveform() if settings.shape == "user" else None
        volts = self.rig.advance(n, settings, wave)
        self._count += n
        if self.realtime:
            wait = self._t0 + self._count / self.sample_rate_hz - time.monotonic()
            if wait > 0:
                time.sleep(wait)
        if out is not None:
            out[...] = volts
            return out
        return volts

    @property
    def samples_read(self) -> int:
        return self._count

    def stop(self) -> None:
        self._running = False

    def close(self) -> None:
        self.stop()
        self._closed = True


def open_sim(rig_config: Any) -> tuple[MemoryGenerator, SimDAQ, Any]:
    """Generator, DAQ and rig for a :class:`labjoint.config.RigConfig` (``[sim]`` table
    validated); ``[sim] rig = "structure"`` selects the structural rig (seed 000)."""
    try:
        channels = rig_config.daq.specs()
        rate = rig_config.daq.sample_rate_hz
    except AttributeError as exc:  # pragma: no cover - not a rig config
        raise ConfigError(f"not a rig config: {exc}", field="daq") from None
    rig: Any
    if (getattr(rig_config, "sim", None) or {}).get("rig") == "structure":
        from labjoint.hardware.sim.structure_config import StructureSimConfig
        from labjoint.hardware.sim.structure_rig import SimStructureRig

        cfg: Any = StructureSimConfig.from_rig(rig_config)
        rig = SimStructureRig(cfg, channels, rate)
    else:
        cfg = SimConfig.from_rig(rig_config)
        rig = SimRig(cfg, channels, rate)
    generator = MemoryGenerator()
    return generator, SimDAQ(rig, generator, realtime=cfg.realtime), rig
