"""The queue's control table: the emergency stop, held jobs, the daemon's published status.

Emergency stop semantics (stated): :meth:`ControlMixin.request_estop` latches the stop and
holds every queued job (status ``held``); a plan submitted while it is latched is held
too. Clearing the stop (:meth:`ControlMixin.clear_estop`) starts nothing by itself: each
held job waits until someone resumes it (:meth:`ControlMixin.resume`, back to ``queued``)
or cancels it. A held job cannot be resumed while the stop is latched.
"""

from __future__ import annotations

import json
import logging
import sqlite3
from collections.abc import Mapping
from typing import Any

from labjoint.documents import utc_now
from labjoint.errors import LabjointError

log = logging.getLogger(__name__)
HELD_MESSAGE = "held by an emergency stop: resume it or cancel it"


class JobStateError(LabjointError):
    """The job is not in a state that allows the request (e.g. cancelling a finished job)."""


class ControlMixin:
    """Control-table methods of :class:`labjoint.daemon.queue.JobQueue`."""

    def _set(self, key: str, value: Any) -> None:
        with self._write() as con:  # type: ignore[attr-defined]
            self._put(con, key, value)

    @staticmethod
    def _put(con: sqlite3.Connection, key: str, value: Any) -> None:
        con.execute("INSERT OR REPLACE INTO control (key, value, updated_at) VALUES (?, ?, ?)",
                    (key, None if value is None else json.dumps(value), utc_now()))

    def _get(self, key: str) -> tuple[Any, str] | None:
        row = self._connect().execute(  # type: ignore[attr-defined]
            "SELECT value, updated_at FROM control WHERE key = ?", (key,)).fetchone()
        if row is None or row["value"] is None:
            return None
        return json.loads(row["value"]), row["updated_at"]

    @staticmethod
    def _estop(con: sqlite3.Connection) -> str | None:
        row = con.execute("SELECT value FROM control WHERE key = 'estop'").fetchone()
        return None if row is None or row["value"] is None else str(json.loads(row["value"]))

    def request_estop(self, reason: str) -> list[str]:
        """Latch the emergency stop (the daemon switches the output off and aborts the
        running job) and hold every queued job; returns the ids held. The reason is stored
        as given and logged escaped (control characters shown as escapes)."""
        text = str(reason) or "emergency stop"
        log.warning("emergency stop latched: %s", text.encode("unicode_escape").decode("ascii"))
        with self._write() as con:  # type: ignore[attr-defined]
            self._put(con, "estop", text)
            ids = [r["id"] for r in con.execute("SELECT id FROM jobs WHERE status = 'queued'")]
            con.execute("UPDATE jobs SET status = 'held', message = ? WHERE status = 'queued'",
                        (HELD_MESSAGE,))
        return ids

    def estop_requested(self) -> str | None:
        """The latched emergency stop's reason, or None."""
        got = self._get("estop")
        return None if got is None else str(got[0])

    def clear_estop(self) -> None:
        """Unlatch the emergency stop; held jobs stay held until resumed (module docstring)."""
        self._set("estop", None)

    def resume(self, job_id: str) -> Any:
        """A held job back to ``queued`` (refused while the emergency stop is latched)."""
        with self._write() as con:  # type: ignore[attr-defined]
            row = self._row(con, job_id)  # type: ignore[attr-defined]
            if row["status"] != "held":
                raise JobStateError(f"job {job_id} is not held ({row['status']})")
            if self._estop(con) is not None:
                raise JobStateError("the emergency stop is still latched: clear it first")
            con.execute("UPDATE jobs SET status = 'queued', message = 'resumed' WHERE id = ?",
                        (job_id,))
        return self.get(job_id)  # type: ignore[attr-defined]

    def set_daemon_status(self, status: Mapping[str, Any]) -> None:
        """Publish the daemon's status for other processes (CLI, REST)."""
        self._set("daemon_status", dict(status))

    def daemon_status(self) -> dict[str, Any] | None:
        """The last status the daemon published, with ``updated_at``; None if never."""
        got = self._get("daemon_status")
        if got is None:
            return None
        value, updated = got
        return {**value, "updated_at": updated}
