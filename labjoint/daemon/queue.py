"""The persistent job queue the CLI and the REST service write to and the daemon reads.

One SQLite file in WAL mode (readers never block the writer), a busy timeout so
concurrent writers wait instead of failing, and one connection per thread, so a
:class:`JobQueue` is safe to share between threads and to open from several processes
at once. (Connections live as long as their thread: closing the last connection to a
WAL database checkpoints it, which would cost milliseconds on every call.) Every
read-modify-write runs inside ``BEGIN IMMEDIATE`` (the write lock is taken before the
read), which makes :meth:`JobQueue.claim_next`, :meth:`JobQueue.cancel` and
:meth:`JobQueue.continue_torque` atomic.

Job life cycle::

    queued -> running <-> waiting_torque -> done | failed | aborted | cancelled
    queued -> cancelled
    queued -> held (an emergency stop) -> queued (an explicit resume) | cancelled

>>> import tempfile, pathlib
>>> q = JobQueue(pathlib.Path(tempfile.mkdtemp()) / "queue.sqlite")
>>> job = q.get(q.submit({"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 2}))
>>> job.status, job.plan["plan"]
('queued', 'dwell')
>>> q.cancel(job.id).status
'cancelled'
"""

from __future__ import annotations

import json
import math
import sqlite3
import uuid
import os
import threading
from contextlib import closing, contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

from labjoint.acquisition.plans import load_plan
from labjoint.daemon.control import HELD_MESSAGE, ControlMixin, JobStateError, utc_now
from labjoint.errors import InputError

JOB_STATUSES = ("queued", "held", "running", "waiting_torque", "done", "failed", "cancelled",
                "aborted")
ACTIVE = ("running", "waiting_torque")
FINISHED = ("done", "failed", "cancelled", "aborted")
BUSY_TIMEOUT_S = 30.0
_SCHEMA_VERSION = 1

_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT UNIQUE NOT NULL,
    status TEXT NOT NULL,
    plan TEXT NOT NULL,
    submitted_by TEXT NOT NULL DEFAULT '',
    submitted_at TEXT NOT NULL,
    started_at TEXT,
    finished_at TEXT,
    progress REAL NOT NULL DEFAULT 0,
    message TEXT NOT NULL DEFAULT '',
    runs TEXT NOT NULL DEFAULT '[]',
    waiting_for TEXT,
    error TEXT,
    worker TEXT,
    cancel_requested INTEGER NOT NULL DEFAULT 0,
    torque_answer REAL,
    gaps TEXT NOT NULL DEFAULT '[]'
);
CREATE INDEX IF NOT EXISTS jobs_status_seq ON jobs(status, seq);
CREATE TABLE IF NOT EXISTS control (
    key TEXT PRIMARY KEY,
    value TEXT,
    updated_at TEXT NOT NULL
);
"""

#: Fields :meth:`JobQueue.update` may set, and how each is stored.
_UPDATABLE = ("status", "started_at", "finished_at", "progress", "message", "runs",
              "waiting_for", "error", "worker", "gaps")
_JSON_FIELDS = ("runs", "waiting_for", "gaps")


class JobNotFound(InputError):
    """No job with this id."""


@dataclass
class Job:
    """One queued plan and what became of it.

    ``runs`` are the names of the run files written (``<data_dir>/<name>.h5``);
    ``waiting_for`` what the daemon waits for while ``waiting_torque`` (e.g.
    ``{'kind': 'torque', 'torque_nm': 8.0}``); ``gaps`` every sample-counter jump seen,
    as ``{'run', 'expected', 'got'}``.
    """

    id: str
    status: str
    plan: dict[str, Any]
    submitted_at: str
    started_at: str | None = None
    finished_at: str | None = None
    progress: float = 0.0
    message: str = ""
    runs: list[str] = field(default_factory=list)
    waiting_for: dict[str, Any] | None = None
    error: str | None = None
    submitted_by: str = ""
    worker: str | None = None
    cancel_requested: bool = False
    gaps: list[dict[str, Any]] = field(default_factory=list)

    @property
    def finished(self) -> bool:
        return self.status in FINISHED

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict of every field."""
        return asdict(self)


def _job(row: sqlite3.Row) -> Job:
    return Job(id=row["id"], status=row["status"], plan=json.loads(row["plan"]),
               submitted_at=row["submitted_at"], started_at=row["started_at"],
               finished_at=row["finished_at"], progress=float(row["progress"]),
               message=row["message"], runs=json.loads(row["runs"]),
               waiting_for=None if row["waiting_for"] is None else json.loads(row["waiting_for"]),
               error=row["error"], submitted_by=row["submitted_by"], worker=row["worker"],
               cancel_requested=bool(row["cancel_requested"]), gaps=json.loads(row["gaps"]))


def validate_plan(plan: Mapping[str, Any]) -> dict[str, Any]:
    """A JSON-serialisable copy of ``plan`` after :func:`load_plan` accepted it."""
    if not isinstance(plan, Mapping):
        raise InputError(f"a plan is a mapping with a 'plan' name, got {type(plan).__name__}",
                         field="plan")
    try:
        data = json.loads(json.dumps(dict(plan), allow_nan=False))
    except (TypeError, ValueError) as exc:
        raise InputError(f"plan parameters must be JSON values: {exc}", field="plan") from None
    gen = load_plan(dict(data))  # raises InputError naming the field
    gen.close()
    return data


class JobQueue(ControlMixin):
    """Jobs in the SQLite database at ``db_path`` (created if missing). ``admit``: a check
    every submitted plan must pass before it is queued (e.g. the rig's limits,
    :func:`labjoint.acquisition.admission.check_plan`); it raises InputError to refuse."""

    def __init__(self, db_path: str | Path,
                 admit: Callable[[dict[str, Any]], None] | None = None) -> None:
        self.db_path = Path(db_path)
        self.admit = admit
        self._local = threading.local()
        try:
            self.db_path.parent.mkdir(parents=True, exist_ok=True)
            with closing(self._new_connection()) as con:
                con.execute("PRAGMA journal_mode=WAL")
                version = con.execute("PRAGMA user_version").fetchone()[0]
                if version > _SCHEMA_VERSION:
                    raise InputError(f"queue schema {version} is newer than this labjoint "
                                     f"({_SCHEMA_VERSION})", file=str(self.db_path))
                con.executescript(_SCHEMA)
                con.execute(f"PRAGMA user_version={_SCHEMA_VERSION}")
        except sqlite3.DatabaseError as exc:
            raise InputError(f"cannot open the job queue: {exc}", file=str(self.db_path)) from None

    # ---- connections ----------------------------------------------------------------
    def _new_connection(self) -> sqlite3.Connection:
        con = sqlite3.connect(self.db_path, timeout=BUSY_TIMEOUT_S, isolation_level=None,
                              check_same_thread=True)
        con.row_factory = sqlite3.Row
        con.execute(f"PRAGMA busy_timeout={int(BUSY_TIMEOUT_S * 1000)}")
        con.execute("PRAGMA synchronous=NORMAL")
        return con

    def _connect(self) -> sqlite3.Connection:
        """This thread's connection (a new one after a fork)."""
        con, pid = getattr(self._local, "con", None), getattr(self._local, "pid", None)
        if con is None or pid != os.getpid():
            con = self._local.con = self._new_connection()
            self._local.pid = os.getpid()
        return con

    @contextmanager
    def _write(self) -> Iterator[sqlite3.Connection]:
        """A transaction holding the write lock from its first statement."""
        con = self._connect()
        con.execute("BEGIN IMMEDIATE")
        try:
            yield con
            con.execute("COMMIT")
        except BaseException:
            if con.in_transaction:
                con.execute("ROLLBACK")
            raise

    def close(self) -> None:
        """Close the calling thread's connection (others close with their threads)."""
        con = getattr(self._local, "con", None)
        self._local.con = None
        if con is not None and getattr(self._local, "pid", None) == os.getpid():
            con.close()

    def _row(self, con: sqlite3.Connection, job_id: str) -> sqlite3.Row:
        row = con.execute("SELECT * FROM jobs WHERE id = ?", (str(job_id),)).fetchone()
        if row is None:
            raise JobNotFound(f"no job {job_id!r}", field="job_id")
        return row

    # ---- submitting and reading -----------------------------------------------------
    def submit(self, plan: Mapping[str, Any], *, submitted_by: str = "") -> str:
        """Validate ``plan`` (``{'plan': name, **parameters}``) and queue it; its job id."""
        data = validate_plan(plan)
        if self.admit is not None:
            self.admit(dict(data))
        job_id = uuid.uuid4().hex
        with self._write() as con:
            held = self._estop(con) is not None
            con.execute("INSERT INTO jobs (id, status, plan, submitted_by, submitted_at, message) "
                        "VALUES (?, ?, ?, ?, ?, ?)",
                        (job_id, "held" if held else "queued", json.dumps(data),
                         str(submitted_by), utc_now(), HELD_MESSAGE if held else ""))
        return job_id

    def get(self, job_id: str) -> Job | None:
        """The job, or None if there is none with this id."""
        row = self._connect().execute("SELECT * FROM jobs WHERE id = ?", (str(job_id),)).fetchone()
        return None if row is None else _job(row)

    def list(self, status: str | None = None, limit: int = 50, offset: int = 0) -> list[Job]:
        """Jobs, newest first, optionally only those with ``status``."""
        if status is not None and status not in JOB_STATUSES:
            raise InputError(f"unknown job status {status!r}; known: {JOB_STATUSES}", field="status")
        for name, v in (("limit", limit), ("offset", offset)):
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise InputError(f"must be a non-negative integer, got {v!r}", field=name)
        sql, args = "SELECT * FROM jobs", []
        if status is not None:
            sql += " WHERE status = ?"
            args.append(status)
        sql += " ORDER BY seq DESC LIMIT ? OFFSET ?"
        rows = self._connect().execute(sql, [*args, limit, offset]).fetchall()
        return [_job(r) for r in rows]

    def counts(self) -> dict[str, int]:
        """Number of jobs in each status."""
        rows = self._connect().execute(
            "SELECT status, COUNT(*) AS n FROM jobs GROUP BY status").fetchall()
        out = dict.fromkeys(JOB_STATUSES, 0)
        out.update({r["status"]: int(r["n"]) for r in rows})
        return out

    # ---- operator requests ----------------------------------------------------------
    def cancel(self, job_id: str) -> Job:
        """Cancel a queued job at once; ask the daemon to abort a running one (output off)."""
        with self._write() as con:
            row = self._row(con, job_id)
            status = row["status"]
            if status in ("queued", "held"):
                con.execute("UPDATE jobs SET status = 'cancelled', finished_at = ?, "
                            "message = 'cancelled before it started' WHERE id = ?",
                            (utc_now(), job_id))
            elif status in ACTIVE:
                con.execute("UPDATE jobs SET cancel_requested = 1, "
                            "message = 'cancel requested' WHERE id = ?", (job_id,))
            else:
                raise JobStateError(f"job {job_id} has already finished ({status})")
            return _job(self._row(con, job_id))

    def continue_torque(self, job_id: str, torque_nm: float) -> Job:
        """Confirm the bolt torque now applied, so a job waiting for it continues.

        A job paused by a plan's ``Pause`` (``waiting_for['kind'] == 'pause'``, real rig)
        is continued the same way; the torque given is then only recorded in the message.
        """
        try:
            t = float(torque_nm)
        except (TypeError, ValueError):
            raise InputError(f"must be a number, got {torque_nm!r}", field="torque_nm") from None
        if not (math.isfinite(t) and t > 0):
            raise InputError(f"torque must be positive and finite, got {torque_nm!r}",
                             field="torque_nm")
        with self._write() as con:
            row = self._row(con, job_id)
            if row["status"] != "waiting_torque":
                raise JobStateError(f"job {job_id} is not waiting for a torque ({row['status']})")
            con.execute("UPDATE jobs SET status = 'running', waiting_for = NULL, "
                        "torque_answer = ?, message = ? WHERE id = ?",
                        (t, f"torque {t:g} N*m confirmed", job_id))
            return _job(self._row(con, job_id))

    # ---- daemon side ----------------------------------------------------------------
    def claim_next(self, worker_id: str) -> Job | None:
        """Atomically take the oldest queued job and mark it running for ``worker_id``."""
        with self._write() as con:
            row = con.execute("SELECT id FROM jobs WHERE status = 'queued' "
                              "ORDER BY seq LIMIT 1").fetchone()
            if row is None:
                return None
            con.execute("UPDATE jobs SET status = 'running', started_at = ?, worker = ?, "
                        "message = 'started' WHERE id = ?", (utc_now(), str(worker_id), row["id"]))
            return _job(self._row(con, row["id"]))

    def update(self, job_id: str, **fields: Any) -> Job:
        """Set any of ``status, started_at, finished_at, progress, message, runs,
        waiting_for, error, worker, gaps``; returns the updated job."""
        if not fields:
            raise InputError("nothing to update", field="fields")
        cols, args = [], []
        for key, value in fields.items():
            if key not in _UPDATABLE:
                raise InputError(f"cannot update {key!r}; updatable: {_UPDATABLE}", field=key)
            if key == "status" and value not in JOB_STATUSES:
                raise InputError(f"unknown job status {value!r}; known: {JOB_STATUSES}",
                                 field="status")
            if key == "progress":
                value = float(value)
                if not 0.0 <= value <= 1.0:
                    raise InputError(f"progress must be in [0, 1], got {value}", field="progress")
            if key in _JSON_FIELDS and value is not None:
                value = json.dumps(value)
            cols.append(f"{key} = ?")
            args.append(value)
        with self._write() as con:
            self._row(con, job_id)
            con.execute(f"UPDATE jobs SET {', '.join(cols)} WHERE id = ?", [*args, job_id])
            return _job(self._row(con, job_id))

    def take_torque_answer(self, job_id: str) -> float | None:
        """The torque confirmed by :meth:`continue_torque` (once; cleared when taken)."""
        with self._write() as con:
            row = self._row(con, job_id)
            if row["torque_answer"] is None:
                return None
            con.execute("UPDATE jobs SET torque_answer = NULL WHERE id = ?", (job_id,))
            return float(row["torque_answer"])

    def fail_orphans(self, reason: str = "daemon restarted") -> list[str]:
        """Mark every job left running (or waiting) by a dead daemon 'failed'; their ids."""
        now = utc_now()
        with self._write() as con:
            ids = [r["id"] for r in con.execute(
                "SELECT id FROM jobs WHERE status IN ('running', 'waiting_torque')").fetchall()]
            con.executemany("UPDATE jobs SET status = 'failed', finished_at = ?, error = ?, "
                            "message = ?, waiting_for = NULL WHERE id = ?",
                            [(now, reason, reason, i) for i in ids])
        return ids
