"""One daemon per queue: an exclusive ``flock`` on ``<queue db>.lock``.

The kernel drops the lock when its holder dies (even by SIGKILL), so a stale lock file
never blocks a restart, and a daemon starting up may safely fail the jobs a dead one
left running.
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

from labjoint.errors import LabjointError


class DaemonBusy(LabjointError):
    """Another daemon already owns this queue (and the rig)."""


class DaemonLock:
    """Exclusive, non-blocking lock on ``path`` holding the owner's pid."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def acquire(self) -> None:
        """Take the lock or raise :class:`DaemonBusy` naming the holder's pid."""
        if self._fd is not None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise DaemonBusy(f"another labjoint daemon (pid {holder}) owns this queue: "
                             f"{self.path}") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        self._fd = fd

    def release(self) -> None:
        """Drop the lock (idempotent)."""
        fd, self._fd = self._fd, None
        if fd is not None:
            try:
                os.ftruncate(fd, 0)
            finally:
                os.close(fd)


def holder_pid(path: str | Path) -> int | None:
    """The pid written in the lock file at ``path`` when that process is alive on this
    host, else None (a dead daemon's file holds no pid, or one no process has)."""
    try:
        text = Path(path).read_text().strip()
        pid = int(text.split()[0]) if text else 0
    except (OSError, ValueError, IndexError):
        return None
    if pid <= 0:
        return None
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return None
    except PermissionError:
        return pid                  # alive, owned by another user
    return pid
