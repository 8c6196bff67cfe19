"""The daemon's operator gate: a torque change (or pause) waits on the job queue.

The engine asks (:meth:`QueueGate.ask`, blocking in the engine's thread); the gate sets
the job to ``waiting_torque`` with what it waits for and polls the database until the
operator answers with :meth:`~labjoint.daemon.queue.JobQueue.continue_torque` (from the
CLI or the REST service, in any process), cancels the job, or the engine aborts.
"""

from __future__ import annotations

import logging
import threading
from typing import Any, Callable

from labjoint.acquisition.gate import GateCancelled, TorqueGate
from labjoint.daemon.queue import JobQueue

log = logging.getLogger(__name__)


class QueueGate(TorqueGate):
    """Operator handshake for job ``job_id`` through ``queue``, polled every ``poll_s``.

    ``apply_torque`` (the simulated rig's ``set_torque``) is called with the confirmed
    torque before the plan continues, standing in for the operator's spanner.
    """

    def __init__(self, queue: JobQueue, job_id: str, poll_s: float = 0.2,
                 apply_torque: Callable[[float], None] | None = None) -> None:
        super().__init__(poll_s=poll_s)
        self.queue = queue
        self.job_id = job_id
        self.apply_torque = apply_torque
        self._waiting: dict[str, Any] | None = None
        self._wake = threading.Event()

    @property
    def pending(self) -> dict[str, Any] | None:
        """What the engine waits for, or None."""
        w = self._waiting
        return None if w is None else dict(w)

    def ask(self, kind: str, abort: threading.Event | None = None, **info: Any) -> dict[str, Any]:
        """Publish ``{'kind': kind, **info}`` on the job and wait for the operator."""
        waiting = {"kind": kind, **info}
        what = (f"tighten the bolt to {info['torque_nm']:g} N*m and confirm" if "torque_nm" in info
                else f"paused: {info.get('reason', kind)}; confirm to continue")
        self.queue.take_torque_answer(self.job_id)  # drop any stale answer
        self._waiting = waiting
        self.queue.update(self.job_id, status="waiting_torque", waiting_for=waiting, message=what)
        log.info("job %s waits for the operator: %s", self.job_id, what)
        try:
            while True:
                if abort is not None and abort.is_set():
                    return {"aborted": True}
                answer = self.queue.take_torque_answer(self.job_id)
                if answer is not None:
                    if kind == "torque" and self.apply_torque is not None:
                        self.apply_torque(answer)
                    return {"torque_nm": answer} if kind == "torque" else {}
                job = self.queue.get(self.job_id)
                if job is None or job.cancel_requested:
                    raise GateCancelled("job cancelled while waiting for the operator")
                self._wake.wait(self.poll_s)
                self._wake.clear()
        finally:
            self._waiting = None
            job = self.queue.get(self.job_id)
            if job is not None and job.status == "waiting_torque":
                self.queue.update(self.job_id, status="running", waiting_for=None)

    def confirm(self, torque_nm: float | None = None) -> None:
        """Answer in-process (same as ``queue.continue_torque``)."""
        w = self._waiting
        t = torque_nm if torque_nm is not None else (w or {}).get("torque_nm", 1.0)
        self.queue.continue_torque(self.job_id, t)
        self.wake()

    def cancel(self, reason: str = "cancelled by the operator") -> None:
        """Cancel the job in-process (same as ``queue.cancel``)."""
        self.queue.cancel(self.job_id)
        self.wake()

    def wake(self) -> None:
        """Make a waiting :meth:`ask` re-check now."""
        self._wake.set()
