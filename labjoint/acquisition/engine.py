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
import signal
import threading
import time
import uuid
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone
from typing import Any, Callable, Iterator, Mapping, Sequence

import numpy as np

from labjoint import __version__
from labjoint.documents import Marker, RunStart, RunStop
from labjoint.acquisition.calibrations import channel_calibrations
from labjoint.acquisition.drive import FLOOR_VPP, Abort, DriveMixin
from labjoint.acquisition.gate import GateCancelled, TorqueGate
from labjoint.acquisition.messages import (Checkpoint, Configure, Measure, Output, Pause, Ramp,
                                           Record, RecordResult, SetTorque, SteadyResult, WaitSteady)
from labjoint.acquisition.sampling import SamplingMixin
from labjoint.config import LimitsConfig, RigConfig
from labjoint.errors import ConfigError, HardwareError, InputError, LimitExceeded
from labjoint.hardware.interfaces import DAQ, GeneratorSettings, SignalGenerator

__all__ = ["FLOOR_VPP", "PlanResult", "RunEngine", "channel_calibrations", "stop_on_signals",
           "utc_now"]

log = logging.getLogger(__name__)

DEFAULT_TORQUE_RATIO = 478.0  # N per N*m, seed 002


def utc_now() -> str:
    """Current UTC time, ISO 8601."""
    return datetime.now(timezone.utc).isoformat()


@dataclass
class PlanResult:
    """How a plan ended, and every run it recorded."""

    status: str
    reason: str = ""
    runs: list[RecordResult] = field(default_factory=list)


@dataclass
class _OpenRun:
    uid: str
    name: str
    start_abs: int
    n: int = 0


class RunEngine(DriveMixin, SamplingMixin):
    """Runs plans on ``generator`` and ``daq`` (configured beforehand), emitting documents
    to ``callbacks``. ``rig`` is the simulated rig's handle (``set_torque``), None on a
    real rig, where ``torque_gate`` lets the operator confirm torque changes and pauses.
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
        self.generator, self.daq, self.limits = generator, daq, limits
        self.calibration_sources = dict(calibration_sources or {})
        self.callbacks = list(callbacks)
        self.clock, self.sleep = clock, sleep
        self.torque_gate, self.rig, self.config = torque_gate, rig, config
        self.block_samples = block_samples
        self.ramp_step_s, self.floor_vpp = ramp_step_s, floor_vpp
        self._gen_lock = threading.RLock()
        self._abort = threading.Event()
        self._abort_reason = ""
        self._thread: int | None = None
        self._output = False
        self._vpp = floor_vpp
        self._target: GeneratorSettings | None = None
        self._readback: GeneratorSettings | None = None
        self._torque: float | None = getattr(rig, "torque_nm", None)
        self._torque_requested: float | None = None
        self._daq_running = False
        self._steady: SteadyResult | None = None
        self._run: _OpenRun | None = None
        self._gen_fault = False
        self.state = "idle"
        self.progress: dict[str, Any] = {}

    # ---- channel roles --------------------------------------------------------------
    def roles(self) -> dict[str, Any]:
        """Displacement, joint-force and reference-force channel names and the backend."""
        names = [c.name for c in self.daq.channels]
        if self.config is not None:
            r = self.config.rig
            roles = {"displacement_channels": list(r.displacement_channels),
                     "joint_force_channel": r.joint_force_channel,
                     "reference_force_channel": r.reference_force_channel,
                     "rig_backend": r.backend}
            for key in ("displacement_channels", "joint_force_channel", "reference_force_channel"):
                for n in np.atleast_1d(roles[key]):
                    if n not in names:
                        raise ConfigError(f"channel {n!r} is not among the DAQ channels {names}",
                                          file=self.config.source or None, field=f"rig.{key}")
            return roles
        chans = self.daq.channels
        return {"displacement_channels": [c.name for c in chans if c.quantity == "displacement"],
                "joint_force_channel": next((c.name for c in chans if c.sensor == "nanocomposite"), None),
                "reference_force_channel": next((c.name for c in chans if c.sensor == "force"), None),
                "rig_backend": "sim" if self.rig is not None else "real"}

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
        with self._gen_lock:
            if self._thread is not None:
                raise RuntimeError("this engine is already running a plan")
            self._thread = threading.get_ident()
        self._roles = roles
        self._abort.clear()
        self._abort_reason = ""
        self._gen_fault = False
        self._plan_name = getattr(plan, "__name__", "plan")
        if not hasattr(plan, "send"):  # a plain list of messages
            plan = (msg for msg in plan)
        self._prefix = (f"{datetime.now(timezone.utc):%Y%m%dT%H%M%SZ}-{uuid.uuid4().hex[:4]}"
                        if name_prefix is None else name_prefix)
        self._records: list[RecordResult] = []
        self._checkpoint: dict[str, Any] | None = None
        self._idn: str | None = None
        self.state, self.progress = "running", {"plan": self._plan_name}
        status, reason, ramp, pending = "complete", "", True, None
        if hasattr(self.rig, "torque_nm"):
            self._torque = float(self.rig.torque_nm)
        try:
            self._sync()
            answer = None
            while True:
                self._check_abort()
                try:
                    msg = plan.send(answer)
                except StopIteration:
                    break
                answer = self._execute(msg)
        except BaseException as exc:  # classified, cleaned up, re-raised if not ours
            status, reason, ramp, pending = self._classify(exc)
        try:
            self._shutdown(ramp)
            if self._run is not None:
                self._close_run(status, reason)
        finally:
            with contextlib.suppress(Exception):
                plan.close()
            self.state, self._thread = "idle", None
        if status != "complete":
            log.warning("plan %s ended %s: %s", self._plan_name, status, reason)
        if pending is not None:
            raise pending
        return PlanResult(status, reason, list(self._records))

    # ---- message dispatch -----------------------------------------------------------
    def _execute(self, msg: Any) -> Any:
        if isinstance(msg, Configure):
            return self._configure(msg.frequency_hz, msg.amplitude_vpp, msg.offset_v)
        if isinstance(msg, Ramp):
            t = self._need_target("Ramp")
            return self._configure(t.frequency_hz, msg.to_vpp, t.offset_v)
        if isinstance(msg, Output):
            return self._output_on() if msg.on else self._output_off()
        if isinstance(msg, SetTorque):
            return self._set_torque(msg.torque_nm)
        if isinstance(msg, Pause):
            return self._operator("pause", reason=msg.reason)
        if isinstance(msg, WaitSteady):
            return self._wait_steady(msg)
        if isinstance(msg, Measure):
            return self._measure(msg)
        if isinstance(msg, Record):
            return self._record(msg)
        if isinstance(msg, Checkpoint):
            self._checkpoint = {"label": msg.label, **msg.data}
            self.progress = {"plan": self._plan_name, "checkpoint": msg.label}
            return None
        raise InputError(f"not a plan message: {msg!r}", field="message")

    # ---- torque and operator --------------------------------------------------------
    def _set_torque(self, torque_nm: float) -> float:
        if self.rig is not None and hasattr(self.rig, "set_torque"):
            was_on = self._output
            self._output_off()
            self.rig.set_torque(torque_nm)
            self._torque = self._torque_requested = float(torque_nm)
            if was_on:
                self._output_on()
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
        was_on = self._output
        self._output_off()
        self.state = "waiting"
        self.progress = {"plan": self._plan_name, "waiting": {"kind": kind, **info}}
        try:
            answer = self.torque_gate.ask(kind, self._abort, **info)
        finally:
            self.state = "running"
        self._check_abort()
        if was_on:
            self._output_on()
        return answer

    # ---- runs -----------------------------------------------------------------------
    def _record(self, msg: Record) -> RecordResult:
        f, fs = self._frequency(), self.daq.sample_rate_hz
        n_total = int(math.ceil(msg.n_cycles * fs / f if msg.n_cycles is not None else msg.duration_s * fs))
        steady = self._steady if self._daq_running else None
        self._start_daq()
        name = f"{self._prefix}_{msg.name}" if self._prefix else msg.name
        uid = uuid.uuid4().hex
        md = self._metadata(msg, steady)
        self._run = _OpenRun(uid, name, self.daq.samples_read)
        self.progress = {"plan": self._plan_name, "run": name}
        self._emit("start", RunStart(uid, name, list(self.daq.channels), fs, md))
        if steady is not None:
            self._emit("marker", Marker(uid, "steady", 0, steady.to_dict()))
        for _ in self._blocks(n_total):
            pass
        return self._close_run("complete", "")

    def _marker(self, name: str, sample_abs: int, data: dict[str, Any]) -> None:
        if self._run is not None:
            self._emit("marker", Marker(self._run.uid, name, max(0, sample_abs - self._run.start_abs), data))

    def _close_run(self, status: str, reason: str) -> RecordResult:
        run, self._run = self._run, None
        end = utc_now()
        doc = RunStop(run.uid, status, reason, end, run.n, {"end_time": end})
        result = RecordResult(run.uid, run.name, status, run.n)
        self._records.append(result)
        if status == "complete":
            self._emit("stop", doc)
        else:  # closing after a fault: every callback gets the stop, whatever the others do
            for cb in self.callbacks:
                try:
                    cb("stop", doc)
                except Exception as exc:
                    log.error("callback %r failed on the stop document: %s", cb, exc)
        return result

    def _metadata(self, msg: Record, steady: SteadyResult | None) -> dict[str, Any]:
        rb, t = self._readback, self._target
        if self._idn is None:
            with self._gen_lock:
                self._idn = self.generator.identify()
        md: dict[str, Any] = dict(msg.metadata)
        md.setdefault("plan", self._plan_name)
        md.setdefault("plan_step", len(self._records))
        md.update({
            "frequency_hz": float(rb.frequency_hz if rb else t.frequency_hz),
            "excitation_vpp": float(rb.amplitude_vpp) if (rb and self._output) else 0.0,
            "offset_v": float(rb.offset_v if rb else t.offset_v),
            "sample_rate_hz": float(self.daq.sample_rate_hz),
            "generator": {**(asdict(rb) if rb else {}), "output": self._output,
                          "requested_vpp": float(t.amplitude_vpp), "idn": self._idn},
            "start_time": utc_now(),
            "software_version": __version__,
            **self._roles,
            "steady": None if steady is None else steady.to_dict(),
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

    def _emit(self, name: str, doc: Any) -> None:
        for cb in self.callbacks:
            cb(name, doc)

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
            return "failed", f"{type(exc).__name__}: {exc}", not self._gen_fault, None
        if isinstance(exc, KeyboardInterrupt):
            return "aborted", "interrupted (KeyboardInterrupt)", False, exc
        return "failed", f"{type(exc).__name__}: {exc}", not self._gen_fault, exc

@contextlib.contextmanager
def stop_on_signals(engine: RunEngine, signals: Sequence[int] = (signal.SIGTERM,)) -> Iterator[None]:
    """Within the block, the given signals trigger ``engine.emergency_stop`` (main thread
    only; Ctrl-C already ends a plan through KeyboardInterrupt)."""
    previous = {}

    def handler(signum: int, frame: Any) -> None:
        engine.emergency_stop(f"signal {signal.Signals(signum).name}")

    for s in signals:
        previous[s] = signal.signal(s, handler)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
