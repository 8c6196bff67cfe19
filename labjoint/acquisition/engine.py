"""The run engine: executes a plan's messages on a generator and a DAQ, emits documents.

Every amplitude change is a ramp at ``limits.ramp_vpp_per_s`` (never a step): while the
output is off the amplitude is parked at the generator's floor, switching on starts
from that floor, switching off ramps down to it first. Every generator change passes
:func:`~labjoint.acquisition.safety.check_settings` and every acquired block
:func:`~labjoint.acquisition.safety.check_block` (the one safety hook).

The DAQ runs while the output is on: ramps read it too (limits are checked while the
amplitude rises, and the simulator's physics sees the ramp as the rig would), and it is
stopped when the output goes off (before any wait for the operator). A
:class:`~labjoint.acquisition.messages.Record` is one run (RunStart, Blocks, Markers,
RunStop); ``Block.first_sample`` and marker samples count from the run's first sample.
``WaitSteady`` and ``Measure`` acquire without storing; a steady state found by
``WaitSteady`` is marked in the next run unless the generator changed in between.

How a plan ends (:class:`PlanResult`, and the open run's RunStop status):

- ``complete``; ``limit`` (a limit tripped: amplitude ramped down, output off);
- ``failed`` on an instrument fault (buffer overrun, generator timeout...): data up to
  the fault are kept, output switched off (ramped if the generator still answers);
- ``aborted`` on :meth:`RunEngine.emergency_stop`, an operator cancel or Ctrl-C: output
  off at once, no ramp.

Exceptions from plan code (or callbacks) and KeyboardInterrupt are re-raised after the
same cleanup; the output is switched off on every path.
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
import time
import uuid
from dataclasses import asdict
from datetime import datetime, timezone
from typing import Any, Callable, Mapping, Sequence

from labjoint import __version__
from labjoint.acquisition.calibrations import channel_calibrations
from labjoint.acquisition.drive import FLOOR_VPP, Abort, AbortSignal, Drive
from labjoint.acquisition.gate import GateCancelled, TorqueGate
from labjoint.acquisition.messages import (Checkpoint, Configure, LoadWaveform, Measure,
                                           Measurement, Message, Output, Pause, PlanResult, Ramp, Record, RecordResult,
                                           SetTorque, SteadyResult, WaitSteady)
from labjoint.acquisition.recorder import Recorder
from labjoint.documents import utc_now
from labjoint.acquisition.roles import engine_roles
from labjoint.acquisition.sampling import Sampler, run_clock
from labjoint.config import LimitsConfig, RigConfig
from labjoint.errors import HardwareError, InputError, LimitExceeded
from labjoint.documents import Marker
from labjoint.hardware.interfaces import DAQ, GeneratorSettings, SignalGenerator

__all__ = ["FLOOR_VPP", "PlanResult", "RunEngine", "channel_calibrations", "utc_now"]

log = logging.getLogger(__name__)

DEFAULT_TORQUE_RATIO = 478.0  # N per N*m, seed 002

#: message type -> name of the RunEngine method that executes it (:func:`command`)
COMMANDS: dict[type, str] = {}


def command(message: type) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Register the decorated engine method as the executor of ``message``."""

    def deco(fn: Callable[..., Any]) -> Callable[..., Any]:
        if message in COMMANDS:
            raise ValueError(f"{message.__name__} already has an executor: {COMMANDS[message]}")
        COMMANDS[message] = fn.__name__
        return fn

    return deco


class RunEngine:
    """Runs plans on ``generator`` and ``daq`` (configured beforehand), emitting documents
    to ``callbacks``. It is composed of a :class:`~labjoint.acquisition.drive.Drive`
    (``drive``: the generator side) and a :class:`~labjoint.acquisition.sampling.Sampler`
    (``sampler``: the DAQ side) sharing one abort flag; each message type is executed by
    the method registered for it with :func:`command` (``COMMANDS``). ``rig`` is the
    simulated rig's handle (``set_torque``), None on a real rig, where ``torque_gate``
    lets the operator confirm torque changes and pauses.
    ``config`` supplies channel roles, the torque-to-normal-force ratio, the backend name
    and the block size; without it roles are inferred from the channels' quantities.
    ``clock``/``sleep`` pace the ramps (tests pass fakes). ``calibration_sources`` maps a
    channel to the provenance of its calibration-table points (dicts with
    ``frequency_hz``, ``n_per_v``, ``runs``...), recorded in each run's metadata beside
    the factor used (see :func:`channel_calibrations`)."""

    def __init__(self, generator: SignalGenerator, daq: DAQ, limits: LimitsConfig,
                 callbacks: Sequence[Callable[[str, Any], None]] = (),
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 torque_gate: TorqueGate | None = None, rig: Any = None, *,
                 config: RigConfig | None = None, block_samples: int | None = None,
                 ramp_step_s: float = 0.05, floor_vpp: float = FLOOR_VPP,
                 calibration_sources: Mapping[str, Sequence[Mapping[str, Any]]] | None = None
                 ) -> None:
        self.generator, self.daq = generator, daq
        self.calibration_sources = dict(calibration_sources or {})
        self.recorder = Recorder(callbacks)
        self.torque_gate, self.rig, self.config = torque_gate, rig, config
        self.block_samples = block_samples
        self._abort = AbortSignal()
        self._thread: int | None = None
        self.drive = Drive(generator, limits, self._abort,
                           acquire=lambda n: self.sampler.consume(n, self._frequency()),
                           changed=self._forget_steady, sample_rate_hz=lambda: daq.sample_rate_hz,
                           clock=clock, sleep=sleep, ramp_step_s=ramp_step_s, floor_vpp=floor_vpp)
        self.sampler = Sampler(daq, limits, self._abort, block=self._block,
                               sink=self.recorder.block, marker=self.recorder.marker)
        self._torque: float | None = getattr(rig, "torque_nm", None)
        self._torque_requested: float | None = None
        self.state = "idle"
        self.progress: dict[str, Any] = {}

    @property
    def limits(self) -> LimitsConfig:
        """The safety limits (one object for the drive and the sampler; replaceable)."""
        return self.drive.limits

    @limits.setter
    def limits(self, value: LimitsConfig) -> None:
        self.drive.limits = self.sampler.limits = value

    # ---- channel roles --------------------------------------------------------------
    def roles(self) -> dict[str, Any]:
        """Displacement, joint-force and reference-force channel names and the backend."""
        return engine_roles(list(self.daq.channels), self.config, self.rig is not None)

    def _block(self) -> int:
        if self.block_samples:
            return int(self.block_samples)
        if self.config is not None:
            return int(self.config.daq.block_samples)
        return max(1, int(self.daq.sample_rate_hz // 10))

    # ---- public control -------------------------------------------------------------
    def run(self, plan: Any, *, name_prefix: str | None = None) -> PlanResult:
        """Execute ``plan`` (a generator, or any iterable of messages) to the end; see the
        module docstring for how it ends.

        Run names are ``<name_prefix>_<Record.name>``; the default prefix is the UTC
        start time plus a random tag, so repeated plans never collide; '' for none.
        """
        roles = self.roles()  # ConfigError if the config's channels are not the DAQ's
        with self.drive.lock:
            if self._thread is not None:
                raise RuntimeError("this engine is already running a plan")
            self._thread = threading.get_ident()
        self._roles = roles
        self.sampler.relative = list(roles["displacement_channels"])
        self.sampler.reference = roles["reference_force_channel"]
        self._abort.clear()
        self._plan_name = getattr(plan, "__name__", "plan")
        if not hasattr(plan, "send"):  # a plain list of messages
            plan = (msg for msg in plan)
        self._prefix = (f"{datetime.now(timezone.utc):%Y%m%dT%H%M%SZ}-{uuid.uuid4().hex[:4]}"
                        if name_prefix is None else name_prefix)
        self.recorder.reset()
        self._checkpoint: dict[str, Any] | None = None
        self._idn: str | None = None
        self.state, self.progress = "running", {"plan": self._plan_name}
        status, reason, ramp, pending = "complete", "", True, None
        if hasattr(self.rig, "torque_nm"):
            self._torque = float(self.rig.torque_nm)
        try:
            self.drive.sync()
            answer = None
            while True:
                self._abort.check()
                try:
                    msg = plan.send(answer)
                except StopIteration:
                    break
                answer = self._execute(msg)
        except BaseException as exc:  # classified, cleaned up, re-raised if not ours
            status, reason, ramp, pending = self._classify(exc)
        try:
            try:
                self.sampler.stop()
            except Exception as exc:
                log.error("stopping the DAQ failed: %s", exc)
            self.drive.shutdown(ramp)
            if self.recorder.open_run is not None:
                self.recorder.close(status, reason)
        finally:
            with contextlib.suppress(Exception):
                plan.close()
            self.state, self._thread = "idle", None
        if status != "complete":
            log.warning("plan %s ended %s: %s", self._plan_name, status, reason)
        if pending is not None:
            raise pending
        return PlanResult(status, reason, list(self.recorder.runs))

    # ---- emergency stop ---------------------------------------------------------------
    def emergency_stop(self, reason: str = "emergency stop") -> None:
        """Output off now (no ramp) and end the running plan with status 'aborted'.

        Safe from any thread or a signal handler; from the engine's own thread (a signal
        handler) it only raises the flag, and the engine switches off at its next step.
        """
        self._abort.set(reason)
        if self.torque_gate is not None:
            self.torque_gate.wake()
        if threading.get_ident() != self._thread:
            self.drive.off_now("emergency stop")

    # ---- message dispatch (the command registry) ----------------------------------------
    def _execute(self, msg: Message) -> Any:
        name = COMMANDS.get(type(msg))
        if name is None:
            raise InputError(f"not a plan message: {msg!r}", field="message")
        return getattr(self, name)(msg)

    @command(Configure)
    def _do_configure(self, msg: Configure) -> GeneratorSettings | None:
        return self.drive.configure(msg.frequency_hz, msg.amplitude_vpp, msg.offset_v)

    @command(LoadWaveform)
    def _do_load_waveform(self, msg: LoadWaveform) -> GeneratorSettings | None:
        return self.drive.load_waveform(msg.points, msg.frequency_hz, msg.amplitude_vpp,
                                        msg.offset_v, msg.band_hz, msg.excitation)

    @command(Ramp)
    def _do_ramp(self, msg: Ramp) -> GeneratorSettings | None:
        return self.drive.ramp(msg.to_vpp)

    @command(Output)
    def _do_output(self, msg: Output) -> GeneratorSettings | None:
        return self.drive.on() if msg.on else self._output_off()

    @command(SetTorque)
    def _do_set_torque(self, msg: SetTorque) -> float:
        return self._set_torque(msg.torque_nm)

    @command(Pause)
    def _do_pause(self, msg: Pause) -> dict[str, Any]:
        return self._operator("pause", reason=msg.reason)

    @command(WaitSteady)
    def _do_wait_steady(self, msg: WaitSteady) -> SteadyResult:
        periodic = self.drive.need_target("WaitSteady").shape != "sine"
        return self.sampler.wait_steady(msg, self._frequency(), per_period_rms=periodic)

    @command(Measure)
    def _do_measure(self, msg: Measure) -> Measurement:
        return self.sampler.measure(msg, self._frequency(), self._roles["reference_force_channel"])

    @command(Record)
    def _do_record(self, msg: Record) -> RecordResult:
        return self._record(msg)

    @command(Checkpoint)
    def _do_checkpoint(self, msg: Checkpoint) -> None:
        self._checkpoint = {"label": msg.label, **msg.data}
        self.progress = {"plan": self._plan_name, "checkpoint": msg.label}

    # ---- the drive and the sampler together ------------------------------------------
    def _frequency(self) -> float:
        return self.drive.need_target("acquisition").frequency_hz

    def _forget_steady(self) -> None:
        """A generator change: a steady state found before it no longer holds."""
        self.sampler.forget()

    def _output_off(self) -> None:
        self.drive.off()
        self.sampler.stop()

    # ---- torque and operator --------------------------------------------------------
    def _set_torque(self, torque_nm: float) -> float:
        if self.rig is not None and hasattr(self.rig, "set_torque"):
            was_on = self.drive.output
            self._output_off()
            self.rig.set_torque(torque_nm)
            self._torque = self._torque_requested = float(torque_nm)
            if was_on:
                self.drive.on()
            return self._torque
        answer = self._operator("torque", torque_nm=float(torque_nm))
        self._torque_requested = float(torque_nm)
        self._torque = float(answer.get("torque_nm", torque_nm))
        return self._torque

    def _operator(self, kind: str, **info: Any) -> dict[str, Any]:
        """Output off, wait on the gate for the operator, restore the output."""
        if self.torque_gate is None:
            if self.rig is not None and kind == "pause":
                log.info("pause skipped (simulated rig, no operator gate): %s", info.get("reason"))
                return {}
            raise HardwareError(f"{kind}: a real rig needs an operator gate (torque_gate) to wait on")
        was_on = self.drive.output
        self._output_off()
        self.state = "waiting"
        self.progress = {"plan": self._plan_name, "waiting": {"kind": kind, **info}}
        try:
            answer = self.torque_gate.ask(kind, self._abort, **info)
        finally:
            self.state = "running"
        self._abort.check()
        if was_on:
            self.drive.on()
        return answer

    # ---- runs -----------------------------------------------------------------------
    def _record(self, msg: Record) -> RecordResult:
        f, fs = self._frequency(), self.daq.sample_rate_hz
        n_total = int(math.ceil(msg.n_cycles * fs / f if msg.n_cycles is not None else msg.duration_s * fs))
        steady = self.sampler.steady if self.sampler.running else None
        self.sampler.start()
        name = f"{self._prefix}_{msg.name}" if self._prefix else msg.name
        uid = uuid.uuid4().hex
        md = self._metadata(msg, steady)
        self.recorder.open(uid, name, self.daq.channels, fs, md, self.daq.samples_read)
        self.progress = {"plan": self._plan_name, "run": name}
        if steady is not None:
            self.recorder.emit("marker", Marker(uid, "steady", 0, steady.to_dict()))
        self.sampler.consume(n_total, f)
        return self.recorder.close("complete", "", self.sampler.drive_frequency())

    def _metadata(self, msg: Record, steady: SteadyResult | None) -> dict[str, Any]:
        rb, t, on = self.drive.readback, self.drive.target, self.drive.output
        if self._idn is None:
            self._idn = self.drive.identify()
        md: dict[str, Any] = dict(msg.metadata)
        md.setdefault("plan", self._plan_name)
        md.setdefault("plan_step", len(self.recorder.runs))
        md.update({
            "frequency_hz": float(rb.frequency_hz if rb else t.frequency_hz),
            "excitation_vpp": float(rb.amplitude_vpp) if (rb and on) else 0.0,
            "offset_v": float(rb.offset_v if rb else t.offset_v),
            "sample_rate_hz": float(self.daq.sample_rate_hz),
            "generator": {**(asdict(rb) if rb else {}), "output": on,
                          "requested_vpp": float(t.amplitude_vpp), "idn": self._idn},
            **run_clock(self.daq), **self.sampler.drive_frequency(),
            "software_version": __version__,
            **self._roles,
            "steady": None if steady is None else steady.to_dict(),
            **({"excitation": dict(self.drive.excitation)} if self.drive.excitation else {}),
            "daq": self._daq_info(),
        })
        md["displacement_channels"] = list(md["displacement_channels"])
        md["calibration"] = channel_calibrations(self.daq.channels, md["frequency_hz"],
                                                 self.calibration_sources)
        if self.config is not None:  # bolt/contact radii, beam mass and support, 478 N/Nm
            md.update(self.config.rig.geometry())
        if self._torque is not None:
            ratio = (self.config.rig.torque_to_normal_n_per_nm if self.config is not None
                     else DEFAULT_TORQUE_RATIO)
            md["torque_nm"] = float(self._torque)
            md["torque_to_normal_n_per_nm"] = float(ratio)
            md["normal_force_n"] = float(self._torque * ratio)  # seed 002: 478 N/Nm
            if self._torque_requested is not None:
                md["torque_requested_nm"] = float(self._torque_requested)
        if self._checkpoint is not None:
            md["checkpoint"] = dict(self._checkpoint)
        return md

    def _daq_info(self) -> dict[str, Any]:
        info: dict[str, Any] = {"sample_rate_hz": float(self.daq.sample_rate_hz),
                                "block_samples": self._block()}
        if self.config is not None:
            info.update(module=self.config.daq.module, device=self.config.daq.device)
        return info

    # ---- endings --------------------------------------------------------------------
    def _classify(self, exc: BaseException) -> tuple[str, str, bool, BaseException | None]:
        """(status, reason, ramp down?, exception to re-raise)."""
        if isinstance(exc, Abort):
            return "aborted", exc.reason, False, None
        if isinstance(exc, GateCancelled):
            return "aborted", f"operator cancelled: {exc}", False, None
        if isinstance(exc, LimitExceeded):
            return "limit", str(exc), True, None
        if isinstance(exc, HardwareError):
            return "failed", f"{type(exc).__name__}: {exc}", not self.drive.fault, None
        if isinstance(exc, KeyboardInterrupt):
            return "aborted", "interrupted (KeyboardInterrupt)", False, exc
        return "failed", f"{type(exc).__name__}: {exc}", not self.drive.fault, exc
