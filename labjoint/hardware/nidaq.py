"""NI DAQ backend through nidaqmx: continuous multi-channel analog input.

Every channel is a voltage channel (raw volts are kept; calibration turns them into
newtons or metres later). IEPE sensors get the module's 2 mA internal current
excitation; coupling is set per channel and checked against what the module offers
(the NI 9233 is AC-coupled only). Samples are read with nidaqmx's
``AnalogMultiChannelReader.read_many_sample`` into a preallocated float64 array of
shape (n_channels, n). A lost-samples error from DAQmx raises
:class:`~labjoint.errors.BufferOverrun` carrying the sample counter.

nidaqmx is imported lazily, so this module imports without the NI-DAQmx C library;
using it without the library raises HardwareError saying so.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from labjoint.errors import BufferOverrun, ConfigError, HardwareError, InputError, InstrumentTimeout
from labjoint.hardware.interfaces import DAQ, ChannelSpec

log = logging.getLogger(__name__)

IEPE_CURRENT_A = 0.002  # NI 9233/9234 internal IEPE excitation
#: DAQmx error names meaning samples were lost (buffer overwritten or FIFO overflow).
OVERRUN_ERRORS = (
    "SAMPLES_NO_LONGER_AVAILABLE",                              # -200279
    "INPUT_FIFO_OVERFLOW",                                      # -200010
    "INPUT_FIFO_OVERFLOW_2",                                    # -200361
    "ACQ_STOPPED_TO_PREVENT_INPUT_BUFFER_OVERWRITE",            # -200222
    "ACQ_STOPPED_TO_PREVENT_INPUT_BUFFER_OVERWRITE_ONE_DATA_XFER_MECH",  # -200613
    "ACQ_STOPPED_TO_PREVENT_INTERMEDIATE_BUFFER_OVERFLOW",      # -200283
    "ADC_OVERRUN",                                              # -200019
    "AI_OVERRUN",                                               # -201319
    "DATA_OVERWRITTEN_IN_DEVICE_MEMORY",                        # -200004
)
TIMEOUT_ERRORS = ("SAMPLES_NOT_YET_AVAILABLE", "TIMEOUT_EXCEEDED")  # -200284, -200221


@dataclass(frozen=True)
class ModuleSpec:
    """What a C Series module offers: couplings, IEPE, input range, sample rates.

    ``rate_base_hz`` and ``max_divider`` describe delta-sigma modules whose rates are
    ``rate_base_hz / n``, n = 1..max_divider; ``max_divider = 0`` means any rate up to
    ``rate_base_hz``.
    """

    couplings: tuple[str, ...]
    iepe: bool
    range_v: float
    rate_base_hz: float
    max_divider: int

    def rates(self) -> np.ndarray:
        """Offered rates, ascending (empty for modules with a continuous rate range)."""
        if self.max_divider == 0:
            return np.empty(0)
        return self.rate_base_hz / np.arange(self.max_divider, 0, -1)


MODULES = {
    "NI 9233": ModuleSpec(("AC",), True, 5.0, 50_000.0, 25),
    "NI 9234": ModuleSpec(("AC", "DC"), True, 5.0, 51_200.0, 31),
    "NI 9239": ModuleSpec(("DC",), False, 10.0, 50_000.0, 31),
    "NI 9215": ModuleSpec(("DC",), False, 10.0, 100_000.0, 0),
}


def module_spec(module: str) -> ModuleSpec:
    try:
        return MODULES[module]
    except KeyError:
        raise ConfigError(f"unknown DAQ module {module!r}; known: {sorted(MODULES)}",
                          field="daq.module") from None


def offered_rate(module: str, requested_hz: float) -> float:
    """The rate the module runs at for a request: the nearest offered rate at or above it
    (delta-sigma modules); a rate outside what the module offers is refused.

    >>> offered_rate("NI 9233", 50000.0)
    50000.0
    >>> offered_rate("NI 9233", 10000.0)
    10000.0
    >>> round(offered_rate("NI 9233", 7000.0), 3)   # 50 kS/s / 7
    7142.857
    """
    spec = module_spec(module)
    r = float(requested_hz)
    top = spec.rate_base_hz
    if not (np.isfinite(r) and 0 < r <= top * (1 + 1e-12)):
        raise InputError(f"{module} samples at up to {top:g} S/s per channel, got {requested_hz!r}",
                         field="daq.sample_rate_hz")
    rates = spec.rates()
    if rates.size == 0:
        return r
    if r < rates[0] * (1 - 1e-12):
        raise InputError(f"{module} offers {rates[0]:g}..{top:g} S/s ({top:g}/n, n = 1.."
                         f"{spec.max_divider}), got {requested_hz!r}", field="daq.sample_rate_hz")
    return float(rates[np.searchsorted(rates, r * (1 - 1e-12))])


def check_channels(module: str, channels: list[ChannelSpec]) -> None:
    """Refuse channels the module cannot measure (coupling, IEPE, range, duplicates)."""
    spec = module_spec(module)
    if not channels:
        raise ConfigError("at least one channel is needed", field="daq.channels")
    seen: dict[str, str] = {}
    for i, ch in enumerate(channels):
        where = f"daq.channels.{ch.name}"
        if ch.coupling not in spec.couplings:
            raise ConfigError(f"{module} is {'/'.join(spec.couplings)}-coupled only; "
                              f"channel {ch.name!r} asks for {ch.coupling}", field=f"{where}.coupling")
        if ch.iepe and not spec.iepe:
            raise ConfigError(f"{module} has no IEPE excitation; channel {ch.name!r} asks for it",
                              field=f"{where}.iepe")
        if ch.iepe and ch.coupling != "AC":
            raise ConfigError(f"IEPE needs AC coupling; channel {ch.name!r} is {ch.coupling}",
                              field=f"{where}.coupling")
        if ch.range_v > spec.range_v * (1 + 1e-12):
            raise ConfigError(f"{module} measures +-{spec.range_v:g} V; channel {ch.name!r} asks "
                              f"for +-{ch.range_v:g} V", field=f"{where}.range_v")
        phys = ch.physical_channel or f"ai{i}"
        if phys in seen:
            raise ConfigError(f"channels {seen[phys]!r} and {ch.name!r} share {phys}",
                              field=f"{where}.physical_channel")
        seen[phys] = ch.name


def _nidaqmx():
    try:
        import nidaqmx
        import nidaqmx.constants
        import nidaqmx.errors
        import nidaqmx.stream_readers
    except ImportError as exc:  # the Python package itself is missing
        raise HardwareError(f"the nidaqmx Python package is not installed: {exc}") from exc
    return nidaqmx


class NIDAQ(DAQ):
    """An NI C Series analog input module (default NI 9233) read continuously.

    ``buffer_s`` sizes the DAQmx input buffer in seconds of samples (at least four
    reads); ``read_timeout_s`` bounds each block read.
    """

    def __init__(self, device: str = "cDAQ1Mod1", module: str = "NI 9233",
                 read_timeout_s: float = 10.0, buffer_s: float = 10.0) -> None:
        self.device = device
        self.module = module
        self.read_timeout_s = read_timeout_s
        self.buffer_s = buffer_s
        self._task = None
        self._reader = None
        self._channels: list[ChannelSpec] = []
        self._rate = 0.0
        self._running = False
        self._samples_read = 0

    @classmethod
    def from_config(cls, daq_config) -> "NIDAQ":
        """Driver for a config's ``[daq]`` table (call :meth:`configure` next)."""
        return cls(device=daq_config.device, module=daq_config.module)

    # ---- DAQ --------------------------------------------------------------------
    def configure(self, channels: list[ChannelSpec], sample_rate_hz: float) -> float:
        check_channels(self.module, channels)
        rate = offered_rate(self.module, sample_rate_hz)
        nidaqmx = _nidaqmx()
        from nidaqmx.constants import (AcquisitionType, Coupling, ExcitationSource,
                                       OverwriteMode, VoltageUnits)
        from nidaqmx.stream_readers import AnalogMultiChannelReader

        self.close()
        try:
            task = nidaqmx.Task()
        except nidaqmx.errors.DaqNotFoundError as exc:
            raise HardwareError(f"NI-DAQmx driver not installed: cannot open {self.device} "
                                f"({self.module}): {exc}") from exc
        except nidaqmx.errors.DaqError as exc:
            raise HardwareError(f"{self.device}: cannot create a DAQmx task: {exc}") from exc
        self._task = task
        try:
            for i, ch in enumerate(channels):
                phys = ch.physical_channel or f"ai{i}"
                if "/" not in phys:
                    phys = f"{self.device}/{phys}"
                chan = task.ai_channels.add_ai_voltage_chan(
                    phys, name_to_assign_to_channel=ch.name, min_val=-ch.range_v,
                    max_val=ch.range_v, units=VoltageUnits.VOLTS)
                chan.ai_coupling = Coupling.AC if ch.coupling == "AC" else Coupling.DC
                if ch.iepe:
                    chan.ai_excit_src = ExcitationSource.INTERNAL
                    chan.ai_excit_val = IEPE_CURRENT_A
            buf = int(max(self.buffer_s * rate, 1000.0))
            task.timing.cfg_samp_clk_timing(rate, sample_mode=AcquisitionType.CONTINUOUS,
                                            samps_per_chan=buf)
            task.in_stream.input_buf_size = buf
            task.in_stream.overwrite = OverwriteMode.DO_NOT_OVERWRITE_UNREAD_SAMPLES
            actual = float(task.timing.samp_clk_rate)
            self._reader = AnalogMultiChannelReader(task.in_stream)
        except nidaqmx.errors.DaqError as exc:
            self.close()
            raise HardwareError(f"{self.device} ({self.module}): configuring the task failed: "
                                f"{exc}") from exc
        if abs(actual - rate) > 1e-6 * rate:
            log.warning("%s: asked for %g S/s, module runs at %g S/s", self.device, rate, actual)
        self._channels = list(channels)
        self._rate = actual
        return actual

    @property
    def channels(self) -> list[ChannelSpec]:
        return list(self._channels)

    @property
    def sample_rate_hz(self) -> float:
        return self._rate

    @property
    def samples_read(self) -> int:
        return self._samples_read

    def start(self) -> None:
        if self._task is None:
            raise HardwareError(f"{self.device}: configure() before start()")
        errors = _nidaqmx().errors
        self._samples_read = 0
        try:
            self._task.start()
        except errors.DaqError as exc:
            raise HardwareError(f"{self.device}: starting acquisition failed: {exc}") from exc
        self._running = True

    def read(self, n_samples: int, out: np.ndarray | None = None) -> np.ndarray:
        """Read the next ``n_samples`` per channel into ``out`` (allocated if None)."""
        if not self._running:
            raise HardwareError(f"{self.device}: read() before start()")
        n = int(n_samples)
        if n <= 0 or n != n_samples:
            raise InputError(f"n_samples must be a positive integer, got {n_samples!r}",
                             field="n_samples")
        shape = (len(self._channels), n)
        if out is None:
            out = np.empty(shape, dtype=np.float64)
        elif out.shape != shape or out.dtype != np.float64 or not out.flags.c_contiguous:
            raise InputError(f"out must be a C-contiguous float64 array of shape {shape}, got "
                             f"{out.dtype} {out.shape}", field="out")
        errors = _nidaqmx().errors
        try:
            got = self._reader.read_many_sample(out, number_of_samples_per_channel=n,
                                                timeout=self.read_timeout_s)
        except errors.DaqError as exc:
            raise self._read_error(exc) from exc
        if got != n:
            raise HardwareError(f"{self.device}: asked for {n} samples per channel, got {got}")
        self._samples_read += n
        return out

    def stop(self) -> None:
        if self._task is None or not self._running:
            return
        self._running = False
        errors = _nidaqmx().errors
        try:
            self._task.stop()
        except errors.DaqError as exc:
            raise HardwareError(f"{self.device}: stopping acquisition failed: {exc}") from exc

    def close(self) -> None:
        """Stop, then release the task; errors on a dead device are logged, not raised."""
        task = self._task
        if task is None:
            return
        try:
            self.stop()
        except HardwareError as exc:
            log.error("%s", exc)
        self._task = None
        self._reader = None
        try:
            task.close()
        except Exception as exc:  # releasing must not raise on a dead device
            log.error("%s: closing the DAQmx task failed: %s", self.device, exc)

    # ---- helpers -------------------------------------------------------------------
    def _read_error(self, exc) -> HardwareError:
        name = getattr(getattr(exc, "error_type", None), "name", "")
        partial = int(getattr(exc, "samps_per_chan_read", 0) or 0)
        if name in OVERRUN_ERRORS:
            err = BufferOverrun(
                f"{self.device}: samples lost (DAQmx {exc.error_code} {name}) after "
                f"{self._samples_read} samples per channel at {self._rate:g} S/s; "
                f"the data read so far is intact")
        elif name in TIMEOUT_ERRORS:
            err = InstrumentTimeout(f"{self.device}: no samples within {self.read_timeout_s:g} s "
                                    f"(DAQmx {exc.error_code}) after {self._samples_read} samples")
        else:
            err = HardwareError(f"{self.device}: read failed after {self._samples_read} samples: {exc}")
        err.samples_read = self._samples_read
        err.partial_samples = partial
        err.error_code = getattr(exc, "error_code", None)
        return err
