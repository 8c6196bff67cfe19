"""Analysis and model jobs: run in a thread pool, recorded in memory and in SQLite.

A job is created ``queued``, becomes ``running`` when a worker takes it and ends
``complete`` (with its result), ``failed`` (with the error) or ``cancelled``. Every
state change is written to ``<data_dir>/api_jobs.sqlite`` so results outlive the
process; jobs a previous process left unfinished are marked failed at start-up.

>>> import tempfile, pathlib, time
>>> runner = JobRunner(JobStore(pathlib.Path(tempfile.mkdtemp()) / "jobs.sqlite"), workers=1)
>>> job = runner.submit("demo", {"x": 2}, lambda req, progress: {"y": req["x"] ** 2})
>>> runner.wait(job.id, timeout=5).result
{'y': 4}
>>> runner.shutdown()
"""

from __future__ import annotations

import json
import logging
import sqlite3
import threading
import uuid
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import closing
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable


from labjoint.compare.jsonsafe import clean as json_safe
from labjoint.documents import utc_now
from labjoint.errors import InputError, LabjointError

log = logging.getLogger(__name__)

FINISHED = ("complete", "failed", "cancelled")
Work = Callable[[dict[str, Any], Callable[[float, str], None]], dict[str, Any]]




@dataclass
class JobRecord:
    """One analysis or model job."""

    id: str
    kind: str
    status: str
    request: dict[str, Any]
    submitted_by: str = ""
    submitted_at: str = ""
    started_at: str | None = None
    finished_at: str | None = None
    progress: float = 0.0
    message: str = ""
    result: dict[str, Any] | None = None
    error: dict[str, Any] | None = None
    cancel_requested: bool = False

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


_COLS = ("id", "kind", "status", "request", "submitted_by", "submitted_at", "started_at",
         "finished_at", "progress", "message", "result", "error")
_JSON = ("request", "result", "error")


class JobStore:
    """SQLite persistence of :class:`JobRecord` (WAL; one short connection per call)."""

    def __init__(self, db_path: str | Path) -> None:
        self.db_path = Path(db_path)
        self.db_path.parent.mkdir(parents=True, exist_ok=True)
        with closing(self._connect()) as con, con:
            con.execute("PRAGMA journal_mode=WAL")
            con.execute("CREATE TABLE IF NOT EXISTS jobs (id TEXT PRIMARY KEY, kind TEXT, "
                        "status TEXT, request TEXT, submitted_by TEXT, submitted_at TEXT, "
                        "started_at TEXT, finished_at TEXT, progress REAL, message TEXT, "
                        "result TEXT, error TEXT)")
            con.execute("CREATE INDEX IF NOT EXISTS jobs_kind ON jobs(kind, submitted_at)")

    def _connect(self) -> sqlite3.Connection:
        con = sqlite3.connect(self.db_path, timeout=30.0)
        con.row_factory = sqlite3.Row
        return con

    def put(self, job: JobRecord) -> None:
        row = [json.dumps(json_safe(getattr(job, c))) if c in _JSON else getattr(job, c)
               for c in _COLS]
        with closing(self._connect()) as con, con:
            con.execute(f"INSERT OR REPLACE INTO jobs ({', '.join(_COLS)}) "
                        f"VALUES ({', '.join('?' for _ in _COLS)})", row)

    def get(self, job_id: str) -> JobRecord | None:
        rows = self._select("SELECT * FROM jobs WHERE id = ?", [job_id])
        return rows[0] if rows else None

    def list(self, kinds: tuple[str, ...], status: str | None = None, limit: int = 50,
             offset: int = 0) -> list[JobRecord]:
        sql = f"SELECT * FROM jobs WHERE kind IN ({', '.join('?' for _ in kinds)})"
        args: list[Any] = list(kinds)
        if status is not None:
            sql += " AND status = ?"
            args.append(status)
        sql += " ORDER BY submitted_at DESC, id LIMIT ? OFFSET ?"
        return self._select(sql, args + [int(limit), int(offset)])

    def fail_unfinished(self, reason: str) -> int:
        """Mark every queued/running job failed (a previous process died); the count."""
        err = json.dumps({"code": "interrupted", "message": reason})
        with closing(self._connect()) as con, con:
            return con.execute("UPDATE jobs SET status = 'failed', error = ?, finished_at = ? "
                               "WHERE status IN ('queued', 'running')",
                               (err, utc_now())).rowcount

    def _select(self, sql: str, args: list[Any]) -> list[JobRecord]:
        with closing(self._connect()) as con:
            rows = con.execute(sql, args).fetchall()
        return [JobRecord(**{c: (json.loads(r[c]) if c in _JSON and r[c] is not None else r[c])
                             for c in _COLS}) for r in rows]


class JobCancelled(Exception):
    """Raised by a job's progress callback once its cancellation was requested."""


@dataclass
class _Live:
    job: JobRecord
    future: Future | None = None
    done: threading.Event = field(default_factory=threading.Event)


class JobRunner:
    """Runs ``work(request, progress)`` callables in ``workers`` threads, recording jobs;
    jobs submitted as ``long`` (minutes: diagnoses, ladders) run in ``long_workers`` threads
    of their own, so a short job never waits behind them. A running job is cancelled
    cooperatively: once asked, its next ``progress`` call raises :class:`JobCancelled`."""

    def __init__(self, store: JobStore, workers: int = 2, long_workers: int = 1) -> None:
        self.store = store
        n = store.fail_unfinished("the service restarted before this job finished")
        if n:
            log.warning("marked %d unfinished jobs of a previous process failed", n)
        self._pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="labjoint-job")
        self._long = ThreadPoolExecutor(max_workers=long_workers,
                                        thread_name_prefix="labjoint-long-job")
        self._live: dict[str, _Live] = {}
        self._lock = threading.Lock()

    def submit(self, kind: str, request: dict[str, Any], work: Work,
               submitted_by: str = "", long: bool = False) -> JobRecord:
        job = JobRecord(id=uuid.uuid4().hex, kind=kind, status="queued",
                        request=json_safe(request), submitted_by=submitted_by,
                        submitted_at=utc_now())
        live = _Live(job)
        with self._lock:
            self._live[job.id] = live
        self.store.put(job)
        live.future = (self._long if long else self._pool).submit(self._run, live, work, request)
        return self._copy(job)

    def _run(self, live: _Live, work: Work, request: dict[str, Any]) -> None:
        job = live.job
        with self._lock:
            if job.status != "queued":
                return
            job.status, job.started_at = "running", utc_now()
        self.store.put(job)

        def progress(fraction: float, message: str = "") -> None:
            if job.cancel_requested:
                raise JobCancelled(job.id)
            job.progress = float(min(max(fraction, 0.0), 1.0))
            job.message = message

        try:
            result = work(request, progress)
        except JobCancelled:
            self._finish(live, "cancelled")
        except InputError as exc:
            self._finish(live, "failed", error={"code": "invalid_input", "message": str(exc),
                                                "field": exc.field})
        except LabjointError as exc:
            self._finish(live, "failed", error={"code": type(exc).__name__, "message": str(exc)})
        except Exception as exc:  # a bug: keep the service up, record and log it
            log.exception("job %s (%s) failed", job.id, job.kind)
            self._finish(live, "failed", error={"code": "internal_error",
                                                "message": f"{type(exc).__name__}: {exc}"})
        else:
            self._finish(live, "complete", result=json_safe(result))

    def _finish(self, live: _Live, status: str, result: dict[str, Any] | None = None,
                error: dict[str, Any] | None = None) -> None:
        job = live.job
        with self._lock:
            job.status, job.finished_at = status, utc_now()
            job.result, job.error = result, error
            if status == "complete":
                job.progress = 1.0
        self.store.put(job)
        live.done.set()
        with self._lock:
            self._live.pop(job.id, None)

    def cancel(self, job_id: str) -> JobRecord | None:
        """Cancel a queued job; ask a running one to stop at its next progress call (its
        ``cancel_requested``); a finished one is returned unchanged."""
        with self._lock:
            live = self._live.get(job_id)
        if live is None:
            return self.store.get(job_id)
        if live.future is not None and live.future.cancel():
            self._finish(live, "cancelled")
        else:
            with self._lock:
                if live.job.status == "running":
                    live.job.cancel_requested = True
        return self._copy(live.job)

    def get(self, job_id: str) -> JobRecord | None:
        with self._lock:
            live = self._live.get(job_id)
            if live is not None:
                return self._copy(live.job)
        return self.store.get(job_id)

    def list(self, kinds: tuple[str, ...], status: str | None = None, limit: int = 50,
             offset: int = 0) -> list[JobRecord]:
        with self._lock:
            live = {k: self._copy(v.job) for k, v in self._live.items()}
        rows = self.store.list(kinds, status, limit, offset)
        return [live.get(r.id, r) for r in rows]

    def wait(self, job_id: str, timeout: float | None = None) -> JobRecord | None:
        """Block until the job has finished (or ``timeout`` s); its record."""
        with self._lock:
            live = self._live.get(job_id)
        if live is not None:
            live.done.wait(timeout)
        return self.get(job_id)

    def shutdown(self, wait: bool = True) -> None:
        self._pool.shutdown(wait=wait, cancel_futures=True)
        self._long.shutdown(wait=wait, cancel_futures=True)
        with self._lock:
            pending = [v for v in self._live.values() if v.job.status == "queued"]
        for live in pending:
            self._finish(live, "cancelled")

    @staticmethod
    def _copy(job: JobRecord) -> JobRecord:
        return JobRecord(**job.to_dict())

