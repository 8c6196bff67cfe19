"""Tektronix AFG1022 function generator over PyVISA (SCPI): set, read back, compare.

The same class drives the real instrument (default VISA backend) and its simulated twin
(``configs/afg1022-sim.yaml`` through pyvisa-sim, ``visa_library='afg1022-sim.yaml@sim'``).
Commands are sent in one fixed long form, since pyvisa-sim matches them literally.

Load: the shaker amplifiers' inputs are high impedance, so the output is set to
``OUTPut<n>:IMPedance INFinity``: the Vpp set is then the open-circuit Vpp the amplifier
sees (AFG1000 range 2 mVpp to 20 Vpp, offset window +-10 V).

Any VISA failure (timeout, unplugged cable, closed session) raises
:class:`~labjoint.errors.InstrumentTimeout` or :class:`~labjoint.errors.HardwareError`
naming the resource and the command, after an attempt to switch the output OFF.
"""

from __future__ import annotations

import functools
import logging
import math
import threading
from pathlib import Path

import numpy as np
import pyvisa
import pyvisa.constants
import pyvisa.errors

from labjoint.errors import ConfigError, HardwareError, InputError, InstrumentTimeout
from labjoint.hardware.interfaces import GeneratorSettings, SignalGenerator

log = logging.getLogger(__name__)

#: The repository's configs folder, the same folder as ``labjoint.config.CONFIG_DIR``
#: (the hardware layer sits below config, so it cannot import it).
CONFIG_DIR = Path(__file__).resolve().parents[2] / "configs"

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
_VISA_FAILURES = (pyvisa.errors.VisaIOError, pyvisa.errors.InvalidSession, OSError)


def _locked(method):
    """Run a driver method under the instance's lock: one SCPI exchange at a time, and
    multi-command sequences (apply) never interleaved with another thread's read-back."""
    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)
    return wrapper


def resolve_visa_library(visa_library: str, config_dir: str | Path | None = None) -> str:
    """Turn a config's ``visa_library`` into what :class:`pyvisa.ResourceManager` takes.

    ``''`` is the default backend, ``'@sim'`` pyvisa-sim's bundled instruments, and
    ``'file.yaml@sim'`` a definition file, relative paths taken from the configs folder.

    >>> resolve_visa_library('')
    ''
    >>> resolve_visa_library('afg1022-sim.yaml@sim').endswith('configs/afg1022-sim.yaml@sim')
    True
    """
    lib = (visa_library or "").strip()
    if not lib.endswith("@sim") or lib == "@sim":
        return lib
    path = Path(lib[: -len("@sim")])
    if not path.is_absolute():
        path = Path(config_dir or CONFIG_DIR) / path
    if not path.is_file():
        raise ConfigError(f"pyvisa-sim instrument definition not found: {path}",
                          field="generator.visa_library")
    return f"{path}@sim"


class AFG1022(SignalGenerator):
    """One channel of a Tektronix AFG1022 producing a sine into a high-impedance load.

    Use :meth:`open` (or ``with AFG1022(...) as gen``) to connect; ``close()`` switches
    the output OFF and releases the instrument, and never raises on a dead link.
    """

    def __init__(self, resource: str, visa_library: str = "", timeout_ms: int = 2000,
                 channel: int = 1, config_dir: str | Path | None = None) -> None:
        self.resource = resource
        self.visa_library = visa_library
        self.timeout_ms = timeout_ms
        self.channel = channel
        self.config_dir = config_dir
        self._res = None
        self._lock = threading.RLock()

    # ---- connection -------------------------------------------------------------
    @classmethod
    def open(cls, resource: str, visa_library: str = "", timeout_ms: int = 2000,
             channel: int = 1, config_dir: str | Path | None = None) -> "AFG1022":
        """Connect, check the instrument is an AFG1022, and return the driver."""
        return cls(resource, visa_library, timeout_ms, channel, config_dir).connect()

    @classmethod
    def from_config(cls, generator_config, config_dir: str | Path | None = None) -> "AFG1022":
        """Connect as a config's ``[generator]`` table says (resource, visa_library, ...)."""
        g = generator_config
        return cls.open(g.resource, g.visa_library, g.timeout_ms, g.channel, config_dir)

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
        lib = resolve_visa_library(self.visa_library, self.config_dir)
        if lib.endswith("@sim"):   # the twin: teach pyvisa-sim the waveform block
            from labjoint.hardware import visa_twin
            visa_twin.install()
        try:
            rm = pyvisa.ResourceManager(lib)
        except (ValueError, OSError) as exc:
            raise HardwareError(f"cannot load VISA library {lib or '(default)'!r} for "
                                f"{self.resource}: {exc}") from exc
        try:
            self._res = rm.open_resource(self.resource, read_termination="\n",
                                         write_termination="\n", timeout=self.timeout_ms)
        except _VISA_FAILURES as exc:
            raise HardwareError(f"cannot open {self.resource} with VISA library "
                                f"{lib or '(default)'!r}: {exc}") from exc
        if not self._res.session:  # VI_NULL: pyvisa-sim reports an unknown resource this way
            self._res = None
            raise HardwareError(f"cannot open {self.resource} with VISA library "
                                f"{lib or '(default)'!r}: resource not found")
        try:
            self.identify()
            self._write("*CLS")
        except BaseException:
            self.release()
            raise
        return self

    def __enter__(self) -> "AFG1022":
        return self.connect()

    @_locked
    def release(self) -> None:
        """Close the VISA session without touching the output (used by ``hw check``)."""
        res, self._res = self._res, None
        if res is None:
            return
        try:
            res.close()
        except Exception as exc:  # a dead link must not stop the caller's cleanup
            log.warning("%s: closing the VISA session failed: %s", self.resource, exc)

    @_locked
    def close(self) -> None:
        """Switch the output OFF (logged, never raised, if the link is dead), then release."""
        if self._res is None:
            return
        self._safe_off()
        self.release()

    # ---- SignalGenerator ----------------------------------------------------------
    @_locked
    def identify(self) -> str:
        idn = self._query("*IDN?")
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
        f, vpp, off = check_sine(frequency_hz, amplitude_vpp, offset_v)
        ch = self.channel
        self._write(f"OUTPut{ch}:IMPedance INFinity")
        self._write(f"SOURce{ch}:FUNCtion:SHAPe SINusoid")
        self._write(f"SOURce{ch}:FREQuency:FIXed {f:.12E}")
        amp_cmd = f"SOURce{ch}:VOLTage:LEVel:IMMediate:AMPLitude {vpp:.12E}VPP"
        off_cmd = f"SOURce{ch}:VOLTage:LEVel:IMMediate:OFFSet {off:.12E}"
        # Keep every intermediate state inside the +-10 V window: shrink first.
        current_off = self._query_float(f"SOURce{ch}:VOLTage:LEVel:IMMediate:OFFSet?")
        if vpp / 2 + abs(current_off) > MAX_ENVELOPE_V_HIGHZ:
            self._write(off_cmd)
            self._write(amp_cmd)
        else:
            self._write(amp_cmd)
            self._write(off_cmd)
        self._check_errors("apply")
        shape = self._query(f"SOURce{ch}:FUNCtion:SHAPe?")
        if not shape.upper().startswith("SIN"):
            raise HardwareError(f"{self.resource}: shape read back as {shape!r}, not a sine")
        load = self._query(f"OUTPut{ch}:IMPedance?")
        if not _is_high_z(load):
            raise HardwareError(f"{self.resource}: load read back as {load!r}, not INFinity")
        got = self.read_settings()
        for name, want, have, res in (("frequency_hz", f, got.frequency_hz, FREQ_RESOLUTION_HZ),
                                      ("amplitude_vpp", vpp, got.amplitude_vpp, _vpp_resolution(vpp)),
                                      ("offset_v", off, got.offset_v, OFFSET_RESOLUTION_V)):
            if abs(have - want) > max(REL_TOL * abs(want), res):
                raise HardwareError(f"{self.resource}: {name} set to {want!r} but read back "
                                    f"{have!r} (tolerance {max(REL_TOL * abs(want), res):g})")
        return got

    @_locked
    def set_output(self, on: bool) -> None:
        self._write(f"OUTPut{self.channel}:STATe {'ON' if on else 'OFF'}")
        state = self._output_state()
        if state != bool(on):
            raise HardwareError(f"{self.resource}: output set {'ON' if on else 'OFF'} but read "
                                f"back {'ON' if state else 'OFF'}")

    @_locked
    def read_settings(self) -> GeneratorSettings:
        ch = self.channel
        return GeneratorSettings(
            frequency_hz=self._query_float(f"SOURce{ch}:FREQuency:FIXed?"),
            amplitude_vpp=self._query_float(f"SOURce{ch}:VOLTage:LEVel:IMMediate:AMPLitude?"),
            offset_v=self._query_float(f"SOURce{ch}:VOLTage:LEVel:IMMediate:OFFSet?"),
            output=self._output_state(),
            shape=_shape_name(self._query(f"SOURce{ch}:FUNCtion:SHAPe?")),
        )

    # ---- SCPI plumbing ------------------------------------------------------------
    def _write(self, cmd: str) -> None:
        if self._res is None:
            raise HardwareError(f"{self.resource}: not connected (sending {cmd!r})")
        try:
            self._res.write(cmd)
        except _VISA_FAILURES as exc:
            raise self._failure(cmd, exc) from exc

    def _query(self, cmd: str) -> str:
        if self._res is None:
            raise HardwareError(f"{self.resource}: not connected (sending {cmd!r})")
        try:
            return self._res.query(cmd).strip()
        except _VISA_FAILURES as exc:
            raise self._failure(cmd, exc) from exc

    def _query_float(self, cmd: str) -> float:
        text = self._query(cmd)
        try:
            value = float(text)
        except ValueError:
            raise HardwareError(f"{self.resource}: {cmd!r} answered {text!r}, not a number") from None
        return value

    def _output_state(self) -> bool:
        cmd = f"OUTPut{self.channel}:STATe?"
        text = self._query(cmd).upper()
        if text in ("1", "ON"):
            return True
        if text in ("0", "OFF"):
            return False
        raise HardwareError(f"{self.resource}: {cmd!r} answered {text!r}, not 0/1/ON/OFF")

    def _check_errors(self, during: str) -> None:
        """Drain ``SYSTem:ERRor?``; raise with the instrument's messages if any."""
        errors = []
        for _ in range(32):
            text = self._query("SYSTem:ERRor?")
            code = text.split(",", 1)[0].strip()
            if code in ("0", "+0"):
                break
            errors.append(text)
        if errors:
            raise HardwareError(f"{self.resource}: instrument reported during {during}: "
                                + "; ".join(errors))

    def _failure(self, cmd: str, exc: Exception) -> HardwareError:
        """Map a VISA failure to a labjoint error, after trying to leave the output OFF."""
        timed_out = (isinstance(exc, pyvisa.errors.VisaIOError)
                     and exc.error_code == pyvisa.constants.StatusCode.error_timeout)
        off = self._safe_off()
        state = "output switched OFF" if off else "could not switch the output OFF"
        if timed_out:
            return InstrumentTimeout(f"{self.resource}: no answer to {cmd!r} within "
                                     f"{self.timeout_ms} ms ({state})")
        return HardwareError(f"{self.resource}: {cmd!r} failed: {exc} ({state})")

    def _safe_off(self) -> bool:
        """Try ``OUTPut<n>:STATe OFF``; True if sent, False (logged) if the link is dead."""
        res = self._res
        if res is None:
            return False
        try:
            res.write(f"OUTPut{self.channel}:STATe OFF")
            return True
        except Exception as exc:  # the safe state must never raise
            log.error("%s: could not switch the output OFF: %s", self.resource, exc)
            return False


    # ---- arbitrary waveforms ------------------------------------------------------
    @_locked
    def load_waveform(self, points) -> int:
        """Load one period into edit memory as 14-bit codes (``DATA:DATA EMEMory`` with an
        IEEE 488.2 block of big-endian uint16), copy it to ``USER<channel>``, and check the
        point count the instrument reports; the points are normalised to a peak of 1
        (:func:`codes_14bit`), so the amplitude setting is the waveform's peak."""
        codes = codes_14bit(points)
        if self._res is None:
            raise HardwareError(f"{self.resource}: not connected (loading a waveform)")
        cmd = "DATA:DATA EMEMory,"
        try:
            self._res.write_binary_values(cmd, codes.tolist(), datatype="H", is_big_endian=True)
        except _VISA_FAILURES as exc:
            raise self._failure(cmd + "<block>", exc) from exc
        self._write(f"DATA:COPY USER{self.channel},EMEMory")
        self._check_errors("waveform load")
        n = self._query_float("DATA:POINts? EMEMory")
        if n != codes.size:
            raise HardwareError(f"{self.resource}: loaded {codes.size} waveform points but the "
                                f"instrument holds {n:g}")
        wave = (codes.astype(float) - CODE_ZERO) / CODE_ZERO
        wave.setflags(write=False)
        self._wave = wave
        return int(codes.size)

    def waveform(self):
        return getattr(self, "_wave", None)

    @_locked
    def apply_waveform(self, frequency_hz: float, amplitude_vpp: float,
                       offset_v: float = 0.0) -> GeneratorSettings:
        """Select ``USER<channel>`` repeated ``frequency_hz`` times per second at
        ``amplitude_vpp``; read every setting back and compare, as :meth:`apply`."""
        if self.waveform() is None:
            raise HardwareError(f"{self.resource}: no arbitrary waveform loaded (load_waveform first)")
        f, vpp, off = check_sine(frequency_hz, amplitude_vpp, offset_v)
        ch = self.channel
        self._write(f"SOURce{ch}:FUNCtion:SHAPe USER{ch}")
        self._write(f"SOURce{ch}:FREQuency:FIXed {f:.12E}")
        amp_cmd = f"SOURce{ch}:VOLTage:LEVel:IMMediate:AMPLitude {vpp:.12E}VPP"
        off_cmd = f"SOURce{ch}:VOLTage:LEVel:IMMediate:OFFSet {off:.12E}"
        current_off = self._query_float(f"SOURce{ch}:VOLTage:LEVel:IMMediate:OFFSet?")
        for cmd in ((off_cmd, amp_cmd) if vpp / 2 + abs(current_off) > MAX_ENVELOPE_V_HIGHZ
                    else (amp_cmd, off_cmd)):
            self._write(cmd)
        self._check_errors("apply_waveform")
        got = self.read_settings()
        if got.shape != "user":
            raise HardwareError(f"{self.resource}: shape read back as {got.shape!r}, not USER{ch}")
        for name, want, have, res in (("frequency_hz", f, got.frequency_hz, FREQ_RESOLUTION_HZ),
                                      ("amplitude_vpp", vpp, got.amplitude_vpp, _vpp_resolution(vpp)),
                                      ("offset_v", off, got.offset_v, OFFSET_RESOLUTION_V)):
            if abs(have - want) > max(REL_TOL * abs(want), res):
                raise HardwareError(f"{self.resource}: {name} set to {want!r} but read back "
                                    f"{have!r} (tolerance {max(REL_TOL * abs(want), res):g})")
        return got

def check_sine(frequency_hz: float, amplitude_vpp: float, offset_v: float) -> tuple[float, float, float]:
    """Refuse a sine outside the AFG1022's high-Z range (InputError names the parameter).

    >>> check_sine(400, 20, 0)
    (400.0, 20.0, 0.0)
    """
    f, vpp, off = float(frequency_hz), float(amplitude_vpp), float(offset_v)
    if not (math.isfinite(f) and MIN_FREQUENCY_HZ <= f <= MAX_FREQUENCY_HZ):
        raise InputError(f"sine frequency must be within {MIN_FREQUENCY_HZ:g}..{MAX_FREQUENCY_HZ:g} Hz "
                         f"on the {MODEL}, got {frequency_hz!r}", field="frequency_hz")
    if not (math.isfinite(vpp) and MIN_VPP_HIGHZ <= vpp <= MAX_VPP_HIGHZ):
        raise InputError(f"amplitude must be within {MIN_VPP_HIGHZ:g}..{MAX_VPP_HIGHZ:g} Vpp "
                         f"(high-Z load) on the {MODEL}, got {amplitude_vpp!r}", field="amplitude_vpp")
    if not (math.isfinite(off) and abs(off) + vpp / 2 <= MAX_ENVELOPE_V_HIGHZ):
        raise InputError(f"|offset| + Vpp/2 must not exceed {MAX_ENVELOPE_V_HIGHZ:g} V (high-Z load) "
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


#: 14-bit waveform codes: 0 is the waveform's -peak, 16382 its +peak, 8191 zero.
CODE_ZERO = 8191
MIN_POINTS, MAX_POINTS = 2, 8192


def codes_14bit(points) -> "np.ndarray":
    """Points as 14-bit codes, normalised to a peak of 1 (InputError names what is wrong).

    >>> codes_14bit([-2.0, 0.0, 1.0, 2.0]).tolist()
    [0, 8191, 12286, 16382]
    """
    x = np.asarray(points, dtype=float).ravel()
    if not MIN_POINTS <= x.size <= MAX_POINTS:
        raise InputError(f"the {MODEL} stores {MIN_POINTS}..{MAX_POINTS} waveform points, "
                         f"got {x.size}", field="points")
    if not np.all(np.isfinite(x)):
        raise InputError("waveform points must be finite", field="points")
    peak = float(np.max(np.abs(x)))
    if peak == 0:
        raise InputError("the waveform is constant zero", field="points")
    return np.round(CODE_ZERO + CODE_ZERO * (x / peak)).astype(np.uint16)


def _shape_name(text: str) -> str:
    """'sine' or 'user' (an arbitrary waveform) or the instrument's word, lower case."""
    t = text.strip().upper()
    if t.startswith("SIN"):
        return "sine"
    if t.startswith("USER") or t.startswith("EMEM"):
        return "user"
    return t.lower()
