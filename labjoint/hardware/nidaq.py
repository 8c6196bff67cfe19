"""NI DAQ backend through nidaqmx: continuous multi-channel analog input.

Every channel is a voltage channel (raw volts are kept; calibration turns them into
newtons or metres later). IEPE sensors get the module's 2 mA internal current
excitation; coupling is set per channel and checked against what the module offers
(the NI 9233 is AC-coupled only). Where excitation switches per channel (NI 9234 user
guide: "IEPE excitation current on or off in AC-coupled mode (in software)") non-IEPE
channels get ``ExcitationSource.NONE``; a module sourcing 2 mA on every input (NI 9233,
no per-channel switch) refuses ``iepe = false`` channels: capacitive-sensor and
nanocomposite outputs must not be fed 2 mA. :func:`check_drive_band` keeps the drive
frequencies where the AC-coupled inputs are flat. ``configure()`` commits the task
(``TaskMode.TASK_COMMIT``), so configuration errors surface before any output is on.
A lost device (USB cDAQ: -50405, -201003, -200045) raises :class:`DeviceLost`; the task
is closed and configured again at the next :meth:`NIDAQ.start`. Samples are read with nidaqmx's
``AnalogMultiChannelReader.read_many_sample`` into a preallocated float64 array of
shape (n_channels, n). A lost-samples error from DAQmx raises
:class:`~labjoint.errors.BufferOverrun` carrying the sample counter.

nidaqmx is imported lazily, so this module imports without the NI-DAQmx C library;
using it without the library raises HardwareError saying so.
"""

from __future__ import annotations

import logging
import time
from typing import Callable

import numpy as np

from labjoint.errors import BufferOverrun, HardwareError, InputError, InstrumentTimeout
from labjoint.hardware.interfaces import DAQ, ChannelSpec
from labjoint.hardware.ni_modules import (IEPE_CURRENT_A, MODULES, ModuleSpec,  # noqa: F401 - re-exported
                                          check_channels, check_drive_band, module_spec,
                                          offered_rate)

log = logging.getLogger(__name__)

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
#: DAQmx codes meaning the device went away (USB cDAQ unplugged, power, hub reset); no
#: recovery without a new task (ni/nidaqmx-python issues 640 and 893: -50405 on USB).
LOST_ERRORS = (-50405, -201003, -200045)  # PAL_TRANSFER_ABORTED, DEV_CANNOT_BE_ACCESSED, DEVICE_REMOVED


class DeviceLost(HardwareError):
    """The DAQ device is gone; the task was closed and is configured again at the next start."""


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
    reads); ``read_timeout_s`` bounds each block read. ``wall_clock`` (POSIX seconds)
    stamps the task start (:attr:`started_at`); ``lost`` says the device went away.
    """

    def __init__(self, device: str = "cDAQ1Mod1", module: str = "NI 9233",
                 read_timeout_s: float = 10.0, buffer_s: float = 10.0,
                 wall_clock: Callable[[], float] = time.time) -> None:
        self.device = device
        self.module = module
        self.read_timeout_s = read_timeout_s
        self.buffer_s = buffer_s
        self.wall_clock = wall_clock
        self.lost = False
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
                                       OverwriteMode, TaskMode, VoltageUnits)
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
                elif module_spec(self.module).iepe_switchable:
                    chan.ai_excit_src = ExcitationSource.NONE  # never the 2 mA by default
            buf = int(max(self.buffer_s * rate, 1000.0))
            task.timing.cfg_samp_clk_timing(rate, sample_mode=AcquisitionType.CONTINUOUS,
                                            samps_per_chan=buf)
            task.in_stream.input_buf_size = buf
            task.in_stream.overwrite = OverwriteMode.DO_NOT_OVERWRITE_UNREAD_SAMPLES
            # Verify and reserve now: a bad channel, rate or a missing device fails here,
            # not at start() with the generator already driving the shakers.
            task.control(TaskMode.TASK_COMMIT)
            actual = float(task.timing.samp_clk_rate)
            self._reader = AnalogMultiChannelReader(task.in_stream)
        except nidaqmx.errors.DaqError as exc:
            self.close()
            if getattr(exc, "error_code", None) in LOST_ERRORS:
                self.lost = True
                raise DeviceLost(f"{self.device} ({self.module}) lost (DAQmx {exc.error_code}): "
                                 f"{exc}") from exc
            raise HardwareError(f"{self.device} ({self.module}): configuring the task failed: "
                                f"{exc}") from exc
        self.lost = False
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
        """Start the task (configured again first if the device was lost); stamp
        :attr:`started_at` with the host clock around ``task.start()``."""
        if self._task is None and self.lost and self._channels:
            log.warning("%s: device was lost; configuring a new task", self.device)
            self.configure(self._channels, self._rate)
        if self._task is None:
            raise HardwareError(f"{self.device}: configure() before start()")
        errors = _nidaqmx().errors
        self._samples_read = 0
        before = self.wall_clock()
        try:
            self._task.start()
        except errors.DaqError as exc:
            raise self._lost_or(exc, HardwareError(f"{self.device}: starting acquisition "
                                                   f"failed: {exc}")) from exc
        after = self.wall_clock()
        self.started_at, self.started_at_uncertainty_s = 0.5 * (before + after), after - before
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
            raise self._lost_or(exc, self._read_error(exc)) from exc
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
            raise self._lost_or(exc, HardwareError(f"{self.device}: stopping acquisition "
                                                   f"failed: {exc}")) from exc

    def close(self) -> None:
        """Stop, then release the task; errors on a dead device are logged, not raised."""
        task = self._task
        if task is None:
            return
        try:
            self.stop()
        except HardwareError as exc:
            log.error("%s", exc)
        if self._task is None:  # closed already: the device was lost
            return
        self._task = None
        self._reader = None
        try:
            task.close()
        except Exception as exc:  # releasing must not raise on a dead device
            log.error("%s: closing the DAQmx task failed: %s", self.device, exc)

    # ---- helpers -------------------------------------------------------------------
    def _lost_or(self, exc, other: HardwareError) -> HardwareError:
        """:class:`DeviceLost` (task closed, configured again at the next start) for the
        device-lost codes, else ``other``."""
        if getattr(exc, "error_code", None) not in LOST_ERRORS:
            return other
        self._running, self.lost = False, True
        task, self._task, self._reader = self._task, None, None
        try:
            if task is not None:
                task.close()
        except Exception as close_exc:  # the device is gone: closing may fail too
            log.error("%s: closing the lost task failed: %s", self.device, close_exc)
        err = DeviceLost(f"{self.device} ({self.module}) lost (DAQmx {exc.error_code}) after "
                         f"{self._samples_read} samples: {exc}; the task is closed and will "
                         "be configured again before the next start")
        err.samples_read, err.error_code = self._samples_read, exc.error_code
        err.partial_samples = int(getattr(exc, "samps_per_chan_read", 0) or 0)
        return err

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
