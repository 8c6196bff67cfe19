"""The watcher of a running job: cancel, emergency stop and daemon stop, and progress."""

from __future__ import annotations

import logging
import threading
from typing import Any, Callable

from labjoint.daemon.monitor import RunTracker
from labjoint.daemon.queue import JobQueue

log = logging.getLogger(__name__)


class JobWatcher:
    """A thread that, every ``poll_s`` while job ``job_id`` runs, asks
    ``abort_request(job_id) -> (kind or None, reason)`` and on a request stops the
    engine (``on_abort(kind)`` records why), writes the job's progress to the queue and
    calls ``publish()``. It never dies while the run goes on; :meth:`finish` ends it."""

    def __init__(self, queue: JobQueue, job_id: str, engine: Any, tracker: RunTracker,
                 n_expected: int | None, *, poll_s: float,
                 abort_request: Callable[[str], tuple[str | None, str]],
                 on_abort: Callable[[str], None], publish: Callable[[], None]) -> None:
        self.queue, self.job_id, self.engine, self.tracker = queue, job_id, engine, tracker
        self.n_expected, self.poll_s = n_expected, poll_s
        self.abort_request, self.on_abort, self.publish = abort_request, on_abort, publish
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"job-{job_id[:8]}-watch",
                                        daemon=True)
        self._thread.start()

    def finish(self) -> None:
        """Stop watching (the job has ended) and wait for the thread."""
        self._done.set()
        self._thread.join()

    def _run(self) -> None:
        while not self._done.wait(self.poll_s):
            try:
                kind, reason = self.abort_request(self.job_id)
                if kind is not None and self.engine.state != "idle":
                    self.on_abort(kind)
                    self.engine.emergency_stop(reason)
                self.queue.update(self.job_id, progress=self.tracker.progress(self.n_expected),
                                  runs=list(self.tracker.runs), gaps=list(self.tracker.gaps))
                self.publish()
            except Exception as exc:  # never let the watcher die while a run goes on
                log.warning("job %s watcher: %s", self.job_id, exc)
