"""The daemon's jobs: take the oldest queued job, run its plan on the rig, record the end.

:class:`JobRunner` is the part of :class:`~labjoint.daemon.daemon.Daemon` that runs one
job: a :class:`~labjoint.acquisition.engine.RunEngine` whose documents go to a
:class:`~labjoint.storage.RunWriter` and a :class:`~labjoint.daemon.monitor.RunTracker`,
a :class:`~labjoint.daemon.watch.JobWatcher` polling for cancel, emergency stop and
daemon stop, and, whatever happened, the writer closed, the generator output switched
off (read back) and the job's final status, runs and gaps written to the queue. The
daemon itself (life cycle, rig, status) is :mod:`labjoint.daemon.daemon`.
"""

from __future__ import annotations

import logging
from datetime import datetime, timezone

from labjoint.acquisition.engine import RunEngine
from labjoint.acquisition.plans import load_plan
from labjoint.daemon.gate import QueueGate
from labjoint.daemon.monitor import RunTracker, expected_records, job_outcome, observe
from labjoint.daemon.queue import Job, utc_now
from labjoint.daemon.watch import JobWatcher
from labjoint.storage import RunWriter

log = logging.getLogger("labjoint.daemon.daemon")


class JobRunner:
    """Running queued jobs, mixed into :class:`~labjoint.daemon.daemon.Daemon` (whose
    attributes these methods use: queue, rig, generator, writer settings, state)."""

    def run_one(self) -> Job | None:
        """Run the oldest queued job to its end and return it; None if none was started
        (empty queue, emergency stop pending, or stopping)."""
        self.start()
        if self._stopping():
            return None
        estop = self.queue.estop_requested()
        if estop is not None:
            if self._gen is not None and self._gen.output is not False:
                self._output_off("emergency stop pending")
            return None
        self.uncatalogued.retry(self.catalog)
        job = self.queue.claim_next(self.worker_id)
        return None if job is None else self._execute(job)

    def _execute(self, job: Job) -> Job:
        log.info("job %s: plan %s", job.id, job.plan.get("plan"))
        tracker = RunTracker()
        n_expected = expected_records(job.plan)
        self._job, self._tracker, self._abort_kind = job, tracker, None
        self._state = "running"
        writer = RunWriter(self.data_dir, catalog=self.catalog,
                           flush_interval_s=self._flush_interval())
        status, message, error, pending = "failed", "", None, None
        watcher = None
        try:
            self._cal.refresh(self._daq)
            engine = self._make_engine(job, [writer, tracker])
            plan = observe(load_plan(dict(job.plan)), tracker, self._daq.sample_rate_hz)
            plan.__name__ = str(job.plan.get("plan", "plan"))
            watcher = JobWatcher(self.queue, job.id, engine, tracker, n_expected,
                                 poll_s=self.poll_s, abort_request=self._abort_request,
                                 on_abort=self._note_abort, publish=self._publish)
            prefix = f"{datetime.now(timezone.utc):%Y%m%dT%H%M%SZ}-{job.id[:8]}"
            result = engine.run(plan, name_prefix=prefix)
            status, message, error = job_outcome(result, tracker.n_gaps, self._cancelled(job.id),
                                                 tracker.unconverged)
        except Exception as exc:  # plan code or a callback crashed: the engine cleaned up
            error = f"{type(exc).__name__}: {exc}"
            message = f"failed: {error}"
            log.exception("job %s crashed", job.id)
        except BaseException as exc:  # KeyboardInterrupt, SystemExit: finish, then re-raise
            status, error, pending = "aborted", f"{type(exc).__name__}: {exc}", exc
            message = f"aborted: {error}"
        finally:
            if watcher is not None:
                watcher.finish()
            try:
                writer.close()  # a run that never got its RunStop is marked incomplete
            except Exception as exc:
                log.error("closing the run writer failed: %s", exc)
            if writer.catalog_pending:  # a catalog outage: the files are complete
                note = self.uncatalogued.add(writer.catalog_pending)
                status, error = ("failed", note) if status == "done" else (status, error)
                message += "; " + note
            off = self._output_off(f"job {job.id} ended")
            self._engine = self._gate = None
            message += "; generator output OFF" if off else "; generator output state UNKNOWN"
            final = self.queue.update(
                job.id, status=status, finished_at=utc_now(), message=message, error=error,
                runs=list(tracker.runs), gaps=list(tracker.gaps), waiting_for=None,
                progress=1.0 if status == "done" else tracker.progress(n_expected))
            self._job, self._state = None, "idle"
            self._publish(force=True)
        if pending is not None:
            raise pending
        log.info("job %s %s: %s", job.id, final.status, final.message)
        return final

    def _make_engine(self, job: Job, callbacks: list) -> RunEngine:
        sim = getattr(self._rig, "sim", None)
        on_operator = self.operator_torque if self.operator_torque is not None else sim is None
        apply = getattr(sim, "set_torque", None) if on_operator else None
        self._gate = QueueGate(self.queue, job.id, self.poll_s, apply_torque=apply)
        self._engine = RunEngine(self._gen, self._daq, self.config.limits, callbacks,
                                 clock=self.clock, sleep=self.sleep, torque_gate=self._gate,
                                 rig=None if on_operator else sim, config=self.config,
                                 calibration_sources=self._cal.sources)
        return self._engine

    def _cancelled(self, job_id: str) -> bool:
        if self._abort_kind is not None:
            return self._abort_kind == "cancel"
        job = self.queue.get(job_id)  # the gate saw the cancel before the watcher did
        return job is not None and job.cancel_requested

    def _note_abort(self, kind: str) -> None:
        self._abort_kind = self._abort_kind or kind

    def _abort_request(self, job_id: str) -> tuple[str | None, str]:
        if self._stopping():
            return "stop", f"daemon stopping: {self.exit_reason or 'stop requested'}"
        estop = self.queue.estop_requested()
        if estop is not None:
            return "estop", f"emergency stop: {estop}"
        job = self.queue.get(job_id)
        if job is not None and job.cancel_requested:
            return "cancel", "cancelled by the operator"
        return None, ""
