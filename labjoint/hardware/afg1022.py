"""Tektronix AFG1022 function generator over PyVISA (SCPI): set, read back, compare.

The same class drives the real instrument (default VISA backend) and its simulated twin
(``configs/afg1022-sim.yaml`` through pyvisa-sim, ``visa_library='afg1022-sim.yaml@sim'``).
Commands are sent in one fixed long form, since pyvisa-sim matches them literally.

Load ``"INF"`` (amplifier inputs are high impedance: 2 mVpp..20 Vpp, |offset| + Vpp/2
<= 10 V) or ``"50"`` (halved). ``OUTPut<n>:IMPedance`` is probed once at connect and, where
the instrument does not answer it, never sent: the configured load stands (logged).
Connect: device clear, ``*IDN?`` (retried once if empty), ``*CLS``, amplitude unit pinned
to Vpp on both channels, load probe. Groups of writes end with ``*OPC?``; ``apply()``
sends only what changed since the last verified state; ramps use ``set_amplitude``.
OFF means both outputs OFF. Why each step: docs/bench-bringup.md (issue 18).

Any VISA failure raises :class:`~labjoint.errors.InstrumentTimeout` or
:class:`~labjoint.errors.HardwareError` naming the resource and the command, after a
device clear (timeouts) and an attempt to switch both outputs OFF; the session is
reopened before the next command.
"""

from __future__ import annotations

import functools
import logging
import math
import threading
from dataclasses import replace
from pathlib import Path

from labjoint.errors import HardwareError, InputError
from labjoint.hardware.afg1022_arb import ArbitraryWaveforms, codes_14bit, shape_name  # noqa: F401
from labjoint.hardware.afg1022_session import CHANNELS, SessionSteps
from labjoint.hardware.interfaces import GeneratorSettings, SignalGenerator
from labjoint.hardware.visa_session import (CONFIG_DIR, device_clear, open_session,  # noqa: F401
                                            probe_query, resolve_visa_library)

log = logging.getLogger(__name__)


MODEL = "AFG1022"
#: Instrument limits for a sine into a high-impedance load (AFG1000 specifications).
MIN_FREQUENCY_HZ = 1e-6
MAX_FREQUENCY_HZ = 25e6
MIN_VPP_HIGHZ = 2e-3
MAX_VPP_HIGHZ = 20.0
MAX_ENVELOPE_V_HIGHZ = 10.0  # |offset| + Vpp/2
#: Read-back tolerance: relative 1e-6 or the instrument's resolution, whichever is larger.
REL_TOL = 1e-6
FREQ_RESOLUTION_HZ = 1e-6
VPP_RESOLUTION = 1e-4  # 0.1 mVpp, or 4 significant digits for large amplitudes
OFFSET_RESOLUTION_V = 1e-3
HIGHZ_OHM = 9.9e37  # SCPI encoding of INFinity
#: Per load: (min Vpp, max Vpp, max |offset| + Vpp/2) (AFG1000 specifications).
LOADS = {"INF": (MIN_VPP_HIGHZ, MAX_VPP_HIGHZ, MAX_ENVELOPE_V_HIGHZ), "50": (1e-3, 10.0, 5.0)}


def _locked(method):
    """Run a driver method under the instance's lock: one SCPI exchange at a time, and
    multi-command sequences (apply) never interleaved with another thread's read-back."""
    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)
    return wrapper



class AFG1022(SessionSteps, ArbitraryWaveforms, SignalGenerator):
    """One channel of a Tektronix AFG1022 producing a sine into a high-impedance load.

    Use :meth:`open` (or ``with AFG1022(...) as gen``) to connect; ``close()`` switches
    the output OFF and releases the instrument, and never raises on a dead link.
    """

    def __init__(self, resource: str, visa_library: str = "", timeout_ms: int = 2000,
                 channel: int = 1, config_dir: str | Path | None = None, load: str = "INF") -> None:
        self.resource = resource
        self.visa_library = visa_library
        self.timeout_ms = timeout_ms
        self.channel = channel
        self.config_dir = config_dir
        self.load = load
        #: Whether OUTPut<n>:IMPedance answered at connect (None before connecting).
        self.load_settable: bool | None = None
        self._res = None
        self._known: GeneratorSettings | None = None  # last state set and read back
        self._stale = False  # a VISA failure happened: reopen before the next command
        self._lock = threading.RLock()

    # ---- connection -------------------------------------------------------------
    @classmethod
    def open(cls, resource: str, visa_library: str = "", timeout_ms: int = 2000,
             channel: int = 1, config_dir: str | Path | None = None, load: str = "INF") -> "AFG1022":
        """Connect, check the instrument is an AFG1022, and return the driver."""
        return cls(resource, visa_library, timeout_ms, channel, config_dir, load).connect()

    @classmethod
    def from_config(cls, generator_config, config_dir: str | Path | None = None) -> "AFG1022":
        """Connect as a config's ``[generator]`` table says (resource, visa_library, ...)."""
        g = generator_config
        return cls.open(g.resource, g.visa_library, g.timeout_ms, g.channel, config_dir,
                        getattr(g, "load", "INF"))

    @property
    def connected(self) -> bool:
        return self._res is not None

    @_locked
    def connect(self) -> "AFG1022":
        """Open the VISA session and identify the instrument (idempotent)."""
        if self._res is not None:
            return self
        if self.channel not in (1, 2):
            raise InputError(f"AFG1022 has channels 1 and 2, got {self.channel!r}",
                             field="generator.channel")
        if not (isinstance(self.timeout_ms, int) and self.timeout_ms > 0):
            raise InputError(f"timeout must be a positive integer (ms), got {self.timeout_ms!r}",
                             field="generator.timeout_ms")
        if self.load not in LOADS:
            raise InputError(f"load must be one of {sorted(LOADS)}, got {self.load!r}",
                             field="generator.load")
        lib = resolve_visa_library(self.visa_library, self.config_dir)
        if lib.endswith("@sim"):   # the twin: teach pyvisa-sim the waveform block
            from labjoint.hardware import visa_twin
            visa_twin.install()
        self._res = open_session(self.resource, lib, self.timeout_ms)
        self._stale, self._known = False, None
        try:
            device_clear(self._res, self.resource)
            idn = self.identify()
            self._write("*CLS")
            for ch in CHANNELS:
                self._write(f"SOURce{ch}:VOLTage:UNIT VPP")
            self._opc("connect")
            self._check_errors("connect")
            self.load_settable = self._probe_load(idn)
        except BaseException:
            self.release()
            raise
        return self

    def __enter__(self) -> "AFG1022":
        return self.connect()

    @_locked
    def release(self) -> None:
        """Close the VISA session without touching the output (used by ``hw check``)."""
        res, self._res, self._known = self._res, None, None
        if res is None:
            return
        try:
            res.close()
        except Exception as exc:  # a dead link must not stop the caller's cleanup
            log.warning("%s: closing the VISA session failed: %s", self.resource, exc)

    @_locked
    def close(self) -> None:
        """Switch both outputs OFF (logged, never raised, if the link is dead; through a
        fresh session after a hardware error), then release."""
        if self._stale:
            try:
                self._reopen()
            except Exception as exc:
                log.error("%s: could not switch the outputs OFF: %s", self.resource, exc)
        self._stale = False
        if self._res is None:
            return
        self._safe_off()
        self.release()

    # ---- SignalGenerator ----------------------------------------------------------
    @_locked
    def identify(self) -> str:
        idn = self._query("*IDN?") or self._query("*IDN?")  # the first can be empty (USB)
        if MODEL not in idn.upper():
            raise HardwareError(f"{self.resource} answered *IDN? with {idn!r}, "
                                f"which is not a Tektronix {MODEL}")
        return idn

    @_locked
    def apply(self, frequency_hz: float, amplitude_vpp: float, offset_v: float = 0.0) -> GeneratorSettings:
        """Set a sine (high-Z load, Vpp units), read every setting back and compare.

        Values outside the instrument's range raise InputError before anything is sent;
        an instrument error or a read-back mismatch raises HardwareError.
        """
        return self._apply_shape("SINusoid", "sine", frequency_hz, amplitude_vpp, offset_v)

    def _apply_shape(self, shape_cmd: str, shape: str, frequency_hz: float, amplitude_vpp: float,
                     offset_v: float) -> GeneratorSettings:
        f, vpp, off = check_sine(frequency_hz, amplitude_vpp, offset_v, self.load)
        ch, known, self._known = self.channel, self._known, None
        if known is not None and known.shape != shape:
            known = None                    # another shape: the full path
        if known is None:  # first apply of this session: everything; later only what changed
            if self.load_settable:
                self._write(f"OUTPut{ch}:IMPedance {'INFinity' if self.load == 'INF' else '50'}")
            self._write(f"SOURce{ch}:FUNCtion:SHAPe {shape_cmd}")
        if known is None or known.frequency_hz != f:
            self._write(f"SOURce{ch}:FREQuency:FIXed {f:.12E}")
        amp_cmd = f"SOURce{ch}:VOLTage:LEVel:IMMediate:AMPLitude {vpp:.12E}VPP"
        off_cmd = f"SOURce{ch}:VOLTage:LEVel:IMMediate:OFFSet {off:.12E}"
        # Keep every intermediate state inside the +-10 V window: shrink first.
        current_off = (known.offset_v if known is not None else
                       self._query_float(f"SOURce{ch}:VOLTage:LEVel:IMMediate:OFFSet?"))
        writes = [c for c, same in ((amp_cmd, known and known.amplitude_vpp == vpp),
                                    (off_cmd, known and known.offset_v == off)) if not same]
        for cmd in writes[::-1] if vpp / 2 + abs(current_off) > LOADS[self.load][2] else writes:
            self._write(cmd)
        self._opc("apply")
        self._check_errors("apply")
        if self.load_settable:
            load = self._query(f"OUTPut{ch}:IMPedance?")
            if _is_high_z(load) != (self.load == "INF"):
                raise HardwareError(f"{self.resource}: load read back as {load!r}, not {self.load}")
        got = self.read_settings()
        if got.shape != shape:
            raise HardwareError(f"{self.resource}: shape read back as {got.shape!r}, not {shape_cmd}")
        for name, want, have, res in (("frequency_hz", f, got.frequency_hz, FREQ_RESOLUTION_HZ),
                                      ("amplitude_vpp", vpp, got.amplitude_vpp, _vpp_resolution(vpp)),
                                      ("offset_v", off, got.offset_v, OFFSET_RESOLUTION_V)):
            if abs(have - want) > max(REL_TOL * abs(want), res):
                raise HardwareError(f"{self.resource}: {name} set to {want!r} but read back "
                                    f"{have!r} (tolerance {max(REL_TOL * abs(want), res):g})")
        self._known = got
        return got

    @_locked
    def set_output(self, on: bool) -> None:
        """ON switches this channel on; OFF switches both channels off (each read back)."""
        for ch in (self.channel,) if on else CHANNELS:
            self._write(f"OUTPut{ch}:STATe {'ON' if on else 'OFF'}")
        if not on:
            self._opc("output OFF")
        for ch in (self.channel,) if on else CHANNELS:
            state = self._output_state(ch)
            if state != bool(on):
                raise HardwareError(f"{self.resource}: output {ch} set {'ON' if on else 'OFF'} "
                                    f"but read back {'ON' if state else 'OFF'}")
        if self._known is not None:
            self._known = replace(self._known, output=bool(on))

    @_locked
    def read_settings(self) -> GeneratorSettings:
        ch = self.channel
        return GeneratorSettings(
            frequency_hz=self._query_float(f"SOURce{ch}:FREQuency:FIXed?"),
            amplitude_vpp=self._query_float(f"SOURce{ch}:VOLTage:LEVel:IMMediate:AMPLitude?"),
            offset_v=self._query_float(f"SOURce{ch}:VOLTage:LEVel:IMMediate:OFFSet?"),
            output=self._output_state(),
            shape=shape_name(self._query(f"SOURce{ch}:FUNCtion:SHAPe?")),
        )

    @_locked
    def set_amplitude(self, amplitude_vpp: float) -> GeneratorSettings:
        """Change only the amplitude (ramps): one write, ``*OPC?``, the error queue and the
        amplitude read back; the rest is the last verified state."""
        known, self._known = self._known, None
        if known is None:  # nothing verified in this session yet: the full path
            s = self.read_settings()
            set_it = self.apply_waveform if s.shape == "user" else self.apply
            return set_it(s.frequency_hz, amplitude_vpp, s.offset_v)
        _, vpp, _ = check_sine(known.frequency_hz, amplitude_vpp, known.offset_v, self.load)
        self._write(f"SOURce{self.channel}:VOLTage:LEVel:IMMediate:AMPLitude {vpp:.12E}VPP")
        self._opc("set_amplitude")
        self._check_errors("set_amplitude")
        have = self._query_float(f"SOURce{self.channel}:VOLTage:LEVel:IMMediate:AMPLitude?")
        if abs(have - vpp) > (tol := max(REL_TOL * vpp, _vpp_resolution(vpp))):
            raise HardwareError(f"{self.resource}: amplitude_vpp set to {vpp!r} but read back "
                                f"{have!r} (tolerance {tol:g})")
        self._known = replace(known, amplitude_vpp=have)
        return self._known

    # ---- SCPI answers ------------------------------------------------------------
    def _output_state(self, channel: int | None = None) -> bool:
        cmd = f"OUTPut{channel or self.channel}:STATe?"
        text = self._query(cmd).upper()
        if text in ("1", "ON"):
            return True
        if text in ("0", "OFF"):
            return False
        raise HardwareError(f"{self.resource}: {cmd!r} answered {text!r}, not 0/1/ON/OFF")

    def _check_errors(self, during: str) -> None:
        """Drain ``SYSTem:ERRor?``; raise with the instrument's messages if any."""
        errors = self._drain_errors()
        if errors:
            raise HardwareError(f"{self.resource}: instrument reported during {during}: "
                                + "; ".join(errors))


def check_sine(frequency_hz: float, amplitude_vpp: float, offset_v: float,
               load: str = "INF") -> tuple[float, float, float]:
    """Refuse a sine outside the AFG1022's range for ``load`` (InputError names the parameter).

    >>> check_sine(400, 20, 0)
    (400.0, 20.0, 0.0)
    """
    f, vpp, off = float(frequency_hz), float(amplitude_vpp), float(offset_v)
    min_vpp, max_vpp, envelope = LOADS[load]
    if not (math.isfinite(f) and MIN_FREQUENCY_HZ <= f <= MAX_FREQUENCY_HZ):
        raise InputError(f"sine frequency must be within {MIN_FREQUENCY_HZ:g}..{MAX_FREQUENCY_HZ:g} Hz "
                         f"on the {MODEL}, got {frequency_hz!r}", field="frequency_hz")
    if not (math.isfinite(vpp) and min_vpp <= vpp <= max_vpp):
        raise InputError(f"amplitude must be within {min_vpp:g}..{max_vpp:g} Vpp "
                         f"({load} ohm load) on the {MODEL}, got {amplitude_vpp!r}", field="amplitude_vpp")
    if not (math.isfinite(off) and abs(off) + vpp / 2 <= envelope):
        raise InputError(f"|offset| + Vpp/2 must not exceed {envelope:g} V ({load} ohm load) "
                         f"on the {MODEL}, got offset {offset_v!r} with {vpp:g} Vpp", field="offset_v")
    return f, vpp, off


def _vpp_resolution(vpp: float) -> float:
    """0.1 mVpp, or one unit of the 4th significant digit for larger amplitudes."""
    return max(VPP_RESOLUTION, 10.0 ** (math.floor(math.log10(vpp)) - 3))


def _is_high_z(text: str) -> bool:
    t = text.strip().upper()
    if t.startswith("INF"):
        return True
    try:
        return float(t) >= HIGHZ_OHM
    except ValueError:
        return False

