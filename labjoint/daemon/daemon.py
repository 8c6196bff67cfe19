"""The headless acquisition daemon: owns the rig, runs queued jobs, streams runs to disk.

On start it takes the queue's lock (one daemon per queue), opens the rig and switches
the generator output OFF (whatever a crashed predecessor left on), recovers run files
a dead writer left "running" (they become "incomplete") and fails the jobs it left
running ("daemon restarted"). Then it takes jobs from the queue one at a time: each
plan runs on a :class:`~labjoint.acquisition.engine.RunEngine` whose documents go to a
:class:`~labjoint.storage.RunWriter` (HDF5, SWMR, flushed at least every second; the
catalog follows) and to a :class:`~labjoint.daemon.monitor.RunTracker` (sample counts,
counter continuity). Samples never stay in memory beyond the block being written.
The sensor calibrations stored in ``<data_dir>/calibrations.json`` (``labjoint
calibrate``) are applied to the DAQ channels when the rig opens and re-read before
every job (:class:`~labjoint.daemon.setup.Calibrations`); each run's metadata records the factor used.

A watcher thread polls the queue every ``poll_s`` while a job runs: a cancel request or
an emergency stop aborts the run (output off at once, no ramp); it also publishes the
job's progress and the daemon's status. SIGTERM/SIGINT stop the current run the same
way and end :meth:`Daemon.run_forever` cleanly. The output is switched off (and read
back) after every job and on every way out, whatever happened.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import threading
import time
from pathlib import Path
from typing import Any, Callable

from labjoint.acquisition.engine import RunEngine
from labjoint.config import RigConfig
from labjoint.daemon.gate import QueueGate
from labjoint.daemon.jobs import JobRunner
from labjoint.daemon.lock import DaemonLock
from labjoint.daemon.monitor import RunTracker, WatchedGenerator
from labjoint.daemon.queue import Job, JobQueue
from labjoint.daemon.setup import (Calibrations, LeftOut, default_paths, open_rig_lazily,
                                   switch_output_off)
from labjoint.errors import HardwareError
from labjoint.storage import Catalog, catalog_for, recover_all

log = logging.getLogger(__name__)

#: How often the daemon's status is written to the queue database (s).
PUBLISH_INTERVAL_S = 1.0


class Daemon(JobRunner):
    """Runs the queue's jobs on the rig described by ``config``.

    ``clock``/``sleep`` pace the engine's ramps; ``rig_factory(config) -> Rig`` replaces
    :func:`~labjoint.acquisition.rig.open_rig` (tests inject faults with it);
    ``operator_torque`` makes torque changes wait for the operator even on the
    simulated rig (the confirmed torque is then applied to the simulation); by default
    only a real rig waits. ``flush_interval_s`` defaults to one second minus one and a
    half DAQ blocks, so flushes (checked on each block) are never more than 1 s apart.
    """

    def __init__(self, config: RigConfig, data_dir: str | Path | None = None,
                 queue_db: str | Path | None = None, poll_s: float = 0.2,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep, *,
                 rig_factory: Callable[[RigConfig], Any] | None = None,
                 operator_torque: bool | None = None, flush_interval_s: float | None = None,
                 worker_id: str | None = None) -> None:
        self.config = config
        self.data_dir, self.queue_db, self.catalog_db = default_paths(config, data_dir, queue_db)
        self.poll_s, self.clock, self.sleep = float(poll_s), clock, sleep
        self.rig_factory = rig_factory or open_rig_lazily
        self.operator_torque = operator_torque
        self.flush_interval_s = flush_interval_s
        self.worker_id = worker_id or f"{socket.gethostname()}:{os.getpid()}"
        self.queue = JobQueue(self.queue_db)
        self.catalog: Catalog | None = None
        self.last_error: str | None = None
        self.exit_reason = ""
        self._lock = DaemonLock(f"{self.queue_db}.lock")
        self._stop = threading.Event()
        self._signalled: str | None = None
        self._state = "stopped"
        self._started = False
        self._rig: Any = None
        self._gen: WatchedGenerator | None = None
        self._daq: Any = None
        self._engine: RunEngine | None = None
        self._gate: QueueGate | None = None
        self._job: Job | None = None
        self._tracker: RunTracker | None = None
        self._abort_kind: str | None = None
        self._cal = Calibrations(config, self.data_dir)
        self._last_publish = -1e300
        self.uncatalogued = LeftOut()    # run files a catalog outage left out of the index
        self._thread: threading.Thread | None = None

    # ---- life cycle -----------------------------------------------------------------
    def start(self) -> None:
        """Lock the queue, open the rig (output OFF), recover files and orphaned jobs."""
        if self._started:
            return
        self._state = "starting"
        self._lock.acquire()
        try:
            self._rig = self.rig_factory(self._cal.initial())
            self._gen = WatchedGenerator(self._rig.generator)
            self._daq = self._rig.daq
            if not self._output_off("daemon start"):
                raise HardwareError(f"cannot switch the generator output off: {self.last_error}")
            self.data_dir.mkdir(parents=True, exist_ok=True)
            self.catalog = catalog_for(self.config, self.data_dir)
            for p in recover_all(self.data_dir, catalog=self.catalog):
                log.warning("recovered %s: marked incomplete", p.name)
            for job_id in self.queue.fail_orphans("daemon restarted"):
                log.warning("job %s was left running by a dead daemon: failed", job_id)
        except BaseException:
            self._close_rig()
            self._lock.release()
            self._state = "stopped"
            raise
        self._started, self._state = True, "idle"
        log.info("daemon %s started: %s rig, data in %s", self.worker_id,
                 self.config.rig.backend, self.data_dir)
        self._publish(force=True)

    def run_forever(self, stop_event: threading.Event | None = None) -> None:
        """Run jobs until :meth:`stop`, ``stop_event`` or SIGTERM/SIGINT (main thread)."""
        if stop_event is not None:
            self._stop = stop_event
        else:
            self._rearm()
        previous = self._install_signals()
        try:
            self.start()
            while not self._stopping():
                if self.run_one() is None and not self._stopping():
                    self._publish()
                    self._stop.wait(self.poll_s)
        except Exception as exc:  # the queue or the rig broke: stop (systemd restarts us)
            self.last_error = self.exit_reason = f"{type(exc).__name__}: {exc}"
            log.exception("daemon failed")
            raise
        finally:
            try:
                self._shutdown()
            finally:
                for s, h in previous.items():
                    signal.signal(s, h)

    def start_in_thread(self) -> threading.Thread:
        """Start (errors raise here) and run :meth:`run_forever` in a daemon thread."""
        if self._thread is not None and self._thread.is_alive():
            return self._thread
        self._rearm()
        self.start()
        t = threading.Thread(target=self.run_forever, name="labjoint-daemon", daemon=True)
        self._thread = t
        t.start()
        return t

    def _rearm(self) -> None:
        """After an earlier stop, allow :meth:`run_forever` to run again."""
        if not self._started and self._stop.is_set():
            self._stop, self._signalled, self.exit_reason = threading.Event(), None, ""

    def stop(self, reason: str = "daemon stopped") -> None:
        """Abort the running job (output off) and make :meth:`run_forever` return."""
        self.exit_reason = self.exit_reason or reason
        self._abort_kind = self._abort_kind or "stop"
        self._stop.set()
        engine = self._engine
        if engine is not None:
            engine.emergency_stop(f"daemon stopping: {self.exit_reason}")

    def emergency_stop(self, reason: str = "emergency stop") -> None:
        """Output off now, abort the running job, start no job until the estop is cleared."""
        self.queue.request_estop(reason)
        self._abort_kind = self._abort_kind or "estop"
        engine = self._engine
        if engine is not None:
            engine.emergency_stop(f"emergency stop: {reason}")
        else:
            self._output_off("emergency stop")
        self._publish(force=True)

    def close(self) -> None:
        """Output OFF, rig closed, queue lock released (what :meth:`run_forever` does on
        its way out; for callers driving :meth:`run_one` themselves)."""
        self._shutdown()

    def __enter__(self) -> "Daemon":
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def rig(self) -> Any:
        """The opened :class:`~labjoint.acquisition.rig.Rig` (None before start)."""
        return self._rig

    def _install_signals(self) -> dict[int, Any]:
        if threading.current_thread() is not threading.main_thread():
            return {}
        return {s: signal.signal(s, self._on_signal) for s in (signal.SIGTERM, signal.SIGINT)}

    def _on_signal(self, signum: int, frame: Any) -> None:
        # Only a plain attribute: a handler taking a lock the interrupted code holds would
        # deadlock. The job's watcher thread (within poll_s) or the idle loop acts on it.
        self._signalled = signal.Signals(signum).name

    def _stopping(self) -> bool:
        """Turn a received signal into :meth:`stop`; True once stopping."""
        if self._signalled is not None and not self._stop.is_set():
            self.stop(f"signal {self._signalled}")
        return self._stop.is_set()

    def _shutdown(self) -> None:
        if not self._started:
            return
        self._state = "stopping"
        off = self._output_off("daemon stopping")
        self._close_rig()
        self._state, self._started = "stopped", False
        self.exit_reason = self.exit_reason or "stopped"
        log.info("daemon stopped (%s); generator output %s", self.exit_reason,
                 "OFF" if off else "state UNKNOWN")
        try:
            self._publish(force=True, output_off_confirmed=off)
        finally:
            self._lock.release()

    def _close_rig(self) -> None:
        rig, self._rig = self._rig, None
        if rig is None:
            return
        try:
            rig.close()
        except Exception as exc:
            self.last_error = f"closing the rig failed: {exc}"
            log.error(self.last_error)

    # ---- jobs: run_one and the job's execution are in :class:`~labjoint.daemon.jobs.JobRunner`

    # ---- generator and status ---------------------------------------------------------
    def _output_off(self, why: str) -> bool:
        """Switch the output off and confirm by read-back; False (and logged) if not."""
        if self._gen is None:
            return False
        failed = switch_output_off(self._gen, why)
        if failed:
            self.last_error = failed
        return failed is None

    def _flush_interval(self) -> float:
        if self.flush_interval_s is not None:
            return float(self.flush_interval_s)
        block_s = self.config.daq.block_samples / float(self._daq.sample_rate_hz)
        return max(0.05, min(1.0, 1.0 - 1.5 * block_s))

    def status(self) -> dict[str, Any]:
        """Rig backend, generator settings/output, current job, run and samples, errors."""
        job, tracker, engine, gate = self._job, self._tracker, self._engine, self._gate
        state = self._state
        if state == "running" and engine is not None and engine.state == "waiting":
            state = "waiting_torque"
        try:
            estop = self.queue.estop_requested()
        except Exception:
            estop = None
        return {
            "state": state, "pid": os.getpid(), "worker_id": self.worker_id,
            "rig_backend": self.config.rig.backend,
            "generator": None if self._gen is None else self._gen.snapshot(),
            "job": None if job is None else job.id,
            "plan": None if job is None else job.plan.get("plan"),
            "run": tracker.run if (job and tracker) else None,
            "run_status": tracker.run_status if (job and tracker) else None,
            "samples": tracker.samples if (job and tracker) else 0,
            "runs": list(tracker.runs) if (job and tracker) else [],
            "gaps": tracker.n_gaps if (job and tracker) else 0,
            "waiting_for": None if gate is None else gate.pending,
            "estop": estop, "last_error": self.last_error, "exit_reason": self.exit_reason,
            "data_dir": str(self.data_dir), "queue_db": str(self.queue_db),
        }

    def _publish(self, force: bool = False, **extra: Any) -> None:
        now = time.monotonic()
        if not force and now - self._last_publish < PUBLISH_INTERVAL_S:
            return
        self._last_publish = now
        try:
            self.queue.set_daemon_status({**self.status(), **extra})
        except Exception as exc:
            log.warning("publishing the daemon status failed: %s", exc)
