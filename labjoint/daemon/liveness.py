"""Is the daemon alive? Its lock's holder and the age of its last published status.

The daemon publishes its status (:meth:`JobQueue.set_daemon_status`) at least every
``PUBLISH_INTERVAL_S`` while idle and at every step of a job; its lock file holds its pid
while it runs (:mod:`labjoint.daemon.lock`). Other processes (the REST service with
``--no-daemon``, ``labjoint status``) read both: no live holder means "not running",
whatever the last status said; a live holder silent for ``STALE_S`` is "not responding".
"""

from __future__ import annotations

from datetime import datetime, timezone
from typing import Any

from labjoint.daemon.lock import holder_pid
from labjoint.daemon.queue import JobQueue

STALE_S = 30.0


def liveness(queue: JobQueue, now: datetime | None = None) -> dict[str, Any]:
    """The daemon's last status with ``running``, ``state`` (``not running`` and
    ``not responding`` where that is the truth; the published one in ``last_state``),
    ``last_heartbeat`` and ``heartbeat_age_s``."""
    now = now or datetime.now(timezone.utc)
    st = dict(queue.daemon_status() or {})
    beat = st.pop("updated_at", None)
    age = None
    if beat:
        try:
            t = datetime.fromisoformat(str(beat))
            age = (now - (t if t.tzinfo else t.replace(tzinfo=timezone.utc))).total_seconds()
        except ValueError:
            age = None
    pid = holder_pid(f"{queue.db_path}.lock")
    last = st.get("state")
    if pid is None:
        state, running = "not running", False
    elif age is None or age > STALE_S:
        state, running = "not responding", True
    else:
        state, running = str(last or "idle"), True
    return {**st, "state": state, "last_state": last, "running": running,
            "last_heartbeat": beat, "heartbeat_age_s": age}
