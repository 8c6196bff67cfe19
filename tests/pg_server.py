"""A throwaway PostgreSQL server for the tests: initdb into a temporary directory, pg_ctl
start on a free localhost port (its unix socket in that directory), stop and remove.

The binaries come from the system (``make postgres`` installs them: Debian's
``postgresql`` package puts them in /usr/lib/postgresql/<major>/bin, which is not on
PATH); the newest found there, else on PATH. initdb refuses to run as root: when the
tests run as root the server runs as the ``postgres`` user the package creates
(``runuser -u postgres``), its directory owned by that user. Clients connect over TCP
with a password (scram-sha-256), as a lab's workers would. When no server can start,
:func:`start` raises :class:`PostgresUnavailable` and the fixture fails the test (never a
silent skip: a catalog that has not been tried on PostgreSQL is not tested).
"""

from __future__ import annotations

import glob
import os
import pwd
import re
import secrets
import shutil
import socket
import subprocess
import tempfile
import uuid
from dataclasses import dataclass
from pathlib import Path

USER = "labjoint"


class PostgresUnavailable(RuntimeError):
    """No PostgreSQL server could be started (binaries missing, initdb or start failed)."""


def find_binary(name: str) -> str:
    """The newest ``name`` (initdb, pg_ctl) under /usr/lib/postgresql/*/bin, else on PATH."""
    def major(p: str) -> int:
        m = re.search(r"/postgresql/(\d+)/", p)
        return int(m.group(1)) if m else 0

    found = sorted(glob.glob(f"/usr/lib/postgresql/*/bin/{name}"), key=major, reverse=True)
    path = found[0] if found else shutil.which(name)
    if not path:
        raise PostgresUnavailable(f"{name} not found under /usr/lib/postgresql/*/bin or on "
                                  "PATH: run `make postgres` (apt-get install postgresql)")
    return path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass
class Server:
    """A running server: ``url`` of its ``postgres`` database (superuser ``labjoint``)."""

    root: Path
    port: int
    password: str
    runner: list[str]

    @property
    def url(self) -> str:
        return self.database_url("postgres")

    def database_url(self, db: str) -> str:
        return f"postgresql://{USER}:{self.password}@127.0.0.1:{self.port}/{db}"

    def new_database(self) -> str:
        """A fresh, empty database on this server; its URL."""
        import psycopg

        name = f"t_{uuid.uuid4().hex[:16]}"
        with psycopg.connect(self.url, autocommit=True) as con:
            con.execute(f"CREATE DATABASE {name}")
        return self.database_url(name)

    def stop(self) -> None:
        subprocess.run([*self.runner, find_binary("pg_ctl"), "-D", str(self.root / "data"),
                        "-m", "immediate", "-w", "stop"], capture_output=True, timeout=60)
        shutil.rmtree(self.root, ignore_errors=True)


def _runner(root: Path) -> list[str]:
    """The command prefix that runs the server's programs (as ``postgres`` when root)."""
    if os.getuid() != 0:
        return []
    try:
        pw = pwd.getpwnam("postgres")
    except KeyError:
        raise PostgresUnavailable("running as root and there is no 'postgres' user to run "
                                  "the server (initdb refuses root): run `make postgres`") from None
    runuser = shutil.which("runuser")
    if not runuser:
        raise PostgresUnavailable("running as root without runuser to start the server as "
                                  "'postgres'")
    for p in [root, *root.rglob("*")]:
        os.chown(p, pw.pw_uid, pw.pw_gid)
    return [runuser, "-u", "postgres", "--"]


def start() -> Server:
    """Initialise and start a server in a new temporary directory."""
    initdb, pg_ctl = find_binary("initdb"), find_binary("pg_ctl")
    # /tmp: short enough for the unix socket's path limit (107 bytes) and, when the server
    # runs as postgres, reachable by that user (a root TMPDIR may not be)
    root = Path(tempfile.mkdtemp(prefix="labjoint-pg-", dir="/tmp" if os.path.isdir("/tmp")
                                 else None))
    try:
        password = secrets.token_urlsafe(12)
        (root / "pw").write_text(password + "\n")
        runner = _runner(root)
        _run([*runner, initdb, "-D", str(root / "data"), "-U", USER, "-A", "scram-sha-256",
              f"--pwfile={root / 'pw'}", "-E", "UTF8", "--no-locale", "--no-sync"], "initdb")
        port = free_port()
        opts = (f"-p {port} -k {root} -c listen_addresses=127.0.0.1 -c fsync=off "
                "-c synchronous_commit=off -c full_page_writes=off -c max_connections=60")
        _run([*runner, pg_ctl, "-D", str(root / "data"), "-l", str(root / "server.log"),
              "-o", opts, "-w", "-t", "60", "start"], "pg_ctl start", log=root / "server.log")
        return Server(root, port, password, runner)
    except BaseException:
        shutil.rmtree(root, ignore_errors=True)
        raise


def _run(cmd: list[str], what: str, log: Path | None = None) -> None:
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise PostgresUnavailable(f"{what} failed: {exc}") from None
    if res.returncode != 0:
        tail = log.read_text()[-2000:] if log is not None and log.exists() else ""
        raise PostgresUnavailable(f"{what} failed ({res.returncode}): {res.stderr[-2000:]}"
                                  f"{tail}")
