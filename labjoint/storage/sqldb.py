"""One door for the catalog's SQL: an embedded SQLite file or a PostgreSQL server.

Callers write one dialect: ``?`` placeholders (translated to ``%s`` for psycopg), types
TEXT / DOUBLE PRECISION / BIGINT (PostgreSQL's REAL is a 4-byte float: never used),
upserts as ``INSERT ... ON CONFLICT (...) DO UPDATE`` (both servers know it), rows as
plain dicts. The few remaining differences are attributes (:attr:`Database.like_ci`).

SQLite: one connection per call (WAL, 30 s busy timeout), write transactions start with
``BEGIN IMMEDIATE``. PostgreSQL: one autocommit connection per process and thread, kept
open; :meth:`Database.transaction` wraps statements in BEGIN/COMMIT.

>>> import tempfile, pathlib
>>> db = Database(pathlib.Path(tempfile.mkdtemp()) / "x.db")
>>> with db.transaction() as tx:
...     _ = tx.execute("CREATE TABLE t (k TEXT PRIMARY KEY, v DOUBLE PRECISION)")
...     _ = tx.execute(db.upsert_sql("t", ["k", "v"], ["k"]), ["a", 1.5])
>>> db.fetchall("SELECT * FROM t WHERE k = ?", ["a"])
[{'k': 'a', 'v': 1.5}]
>>> redact_url("postgresql://lab:s3cret@db.example:5432/labjoint")
'postgresql://lab:***@db.example:5432/labjoint'
"""

from __future__ import annotations

import functools
import os
import sqlite3
import threading
import weakref
from contextlib import closing, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Sequence
from urllib.parse import urlsplit, urlunsplit

from labjoint.errors import ConfigError

POSTGRES_SCHEMES = ("postgresql", "postgres")
BUSY_TIMEOUT_S = 30.0
CONNECT_TIMEOUT_S = 10
#: kept connections a forked child inherited: never closed nor freed by the child (closing
#: would end the parent's session on the shared socket)
_INHERITED: list[Any] = []


def _close_kept(kept: list[tuple[int, Any]]) -> None:
    """Close the kept connections this process opened; park those of a parent process."""
    pid = os.getpid()
    for owner, con in kept:
        if owner != pid:
            _INHERITED.append(con)
            continue
        try:
            con.close()
        except Exception:     # pragma: no cover - closing is best effort
            pass
    kept.clear()


def is_postgres_url(target: Any) -> bool:
    """True for a ``postgresql://`` (or ``postgres://``) connection URL."""
    return isinstance(target, str) and urlsplit(target).scheme in POSTGRES_SCHEMES


def redact_url(url: str) -> str:
    """``url`` with its password replaced by ``***`` (for messages and logs)."""
    parts = urlsplit(url)
    if parts.password is None:
        return url
    host = parts.netloc.rsplit("@", 1)[1]
    return urlunsplit(parts._replace(netloc=f"{parts.username or ''}:***@{host}"))


@functools.lru_cache(maxsize=512)
def to_pyformat(sql: str) -> str:
    """``?`` placeholders to psycopg's ``%s``, literal ``%`` doubled; quoted text kept.

    >>> to_pyformat("SELECT * FROM t WHERE a = ? AND b LIKE '%?' ESCAPE '\\\\'")
    "SELECT * FROM t WHERE a = %s AND b LIKE '%%?' ESCAPE '\\\\'"
    """
    out, quoted = [], False
    for ch in sql:
        if ch == "'":
            quoted = not quoted      # '' inside a literal toggles twice: still quoted
        elif ch == "%":
            ch = "%%"
        elif ch == "?" and not quoted:
            ch = "%s"
        out.append(ch)
    return "".join(out)


@dataclass
class Result:
    """What a statement gave: its rows (dicts; empty for statements without rows)."""

    rows: list[dict[str, Any]] = field(default_factory=list)
    rowcount: int = -1

    def first(self) -> dict[str, Any] | None:
        return self.rows[0] if self.rows else None


class Session:
    """Statements on one connection (inside a transaction when from :meth:`transaction`)."""

    def __init__(self, db: Database, con: Any) -> None:
        self.db, self.con = db, con

    def execute(self, sql: str, args: Sequence[Any] = ()) -> Result:
        """Run ``sql`` with ``?`` placeholders bound to ``args``."""
        if self.db.dialect == "postgresql":
            cur = self.con.execute(to_pyformat(sql), list(args))
            rows = cur.fetchall() if cur.description else []
            return Result(rows, cur.rowcount)
        cur = self.con.execute(sql, list(args))
        names = [d[0] for d in cur.description] if cur.description else None
        rows = [dict(zip(names, r)) for r in cur.fetchall()] if names else []
        return Result(rows, cur.rowcount)

    def lock(self, key: str) -> None:
        """Hold a lock on ``key`` until the transaction ends, so two writers checking and
        then writing the same key take turns (PostgreSQL: an advisory lock on its hash;
        SQLite's ``BEGIN IMMEDIATE`` already holds the whole database)."""
        if self.db.dialect == "postgresql":
            self.execute("SELECT pg_advisory_xact_lock(hashtext(?))", [key])


class Database:
    """A SQLite file (a path) or a PostgreSQL database (a ``postgresql://`` URL).

    ``label`` names it in messages (the path, or the URL without its password).
    """

    def __init__(self, target: str | Path) -> None:
        self._local = threading.local()
        self._kept: list[tuple[int, Any]] = []       # (pid, connection) kept open
        self._kept_lock = threading.Lock()
        self._generation = 0                          # bumped by close()
        weakref.finalize(self, _close_kept, self._kept)
        if is_postgres_url(target):
            self.dialect, self.url, self.path = "postgresql", str(target), None
            self.label = redact_url(self.url)
            try:
                import psycopg
                import psycopg.rows
            except ImportError:                                   # pragma: no cover
                raise ConfigError("a PostgreSQL catalog needs psycopg (pip install "
                                  "'psycopg[binary]')", field="rig.catalog_url") from None
            self._pg = psycopg
        else:
            self.dialect, self.url, self.path = "sqlite", "", Path(target)
            self.label = str(self.path)
            self.path.parent.mkdir(parents=True, exist_ok=True)

    @property
    def like_ci(self) -> str:
        """The operator matching text ignoring ASCII case (SQLite's LIKE does)."""
        return "ILIKE" if self.dialect == "postgresql" else "LIKE"

    @property
    def errors(self) -> tuple[type[BaseException], ...]:
        """The driver's error classes (to catch a failed statement)."""
        return (self._pg.Error,) if self.dialect == "postgresql" else (sqlite3.Error,)

    # -- connections -------------------------------------------------------------
    def _sqlite(self, check_same_thread: bool = True) -> sqlite3.Connection:
        try:
            con = sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S, isolation_level=None,
                                  check_same_thread=check_same_thread)
            con.execute("PRAGMA synchronous=NORMAL")  # WAL: durable enough for an index
        except sqlite3.Error as exc:
            raise ConfigError(f"cannot open catalog: {exc}", file=self.label) from None
        return con

    def _postgres(self) -> Any:
        """This process's and thread's connection (opened on first use, reopened if lost)."""
        con = getattr(self._local, "con", None)
        if con is not None and (self._local.pid != os.getpid() or con.closed or con.broken):
            con = None        # a forked child never uses its parent's socket
        if con is None:
            pg = self._pg
            try:
                con = pg.connect(self.url, autocommit=True, connect_timeout=CONNECT_TIMEOUT_S,
                                 row_factory=pg.rows.dict_row)
            except pg.Error as exc:
                msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                pw = urlsplit(self.url).password
                if pw:
                    msg = msg.replace(pw, "***")
                raise ConfigError(f"cannot connect to the PostgreSQL catalog {self.label}: "
                                  f"{msg}", field="rig.catalog_url") from None
            self._keep(con)
            self._local.con, self._local.pid = con, os.getpid()
        return con

    def _keep(self, con: Any) -> None:
        with self._kept_lock:
            self._kept.append((os.getpid(), con))

    @contextmanager
    def session(self) -> Iterator[Session]:
        """Statements each committed on its own (reads, single writes)."""
        if self.dialect == "postgresql":
            yield Session(self, self._postgres())
            return
        with closing(self._sqlite()) as con:
            yield Session(self, con)

    @contextmanager
    def reader(self) -> Iterator[Session]:
        """Read-only statements on a connection kept open for this process and thread
        (a hot path: opening a SQLite connection costs several times a keyed lookup)."""
        if self.dialect == "postgresql":
            yield Session(self, self._postgres())
            return
        con = getattr(self._local, "ro", None)
        if con is None or self._local.ro_key != (os.getpid(), self._generation):
            con = self._sqlite(check_same_thread=False)     # closed by close() in any thread
            con.execute("PRAGMA query_only = ON")
            self._keep(con)
            self._local.ro, self._local.ro_key = con, (os.getpid(), self._generation)
        yield Session(self, con)

    @contextmanager
    def transaction(self) -> Iterator[Session]:
        """Statements committed together, or none of them if the block raises.

        SQLite takes the write lock at the start (``BEGIN IMMEDIATE``), so a transaction
        that reads before it writes never dead-locks with another writer."""
        if self.dialect == "postgresql":
            con = self._postgres()
            with con.transaction():
                yield Session(self, con)
            return
        with closing(self._sqlite()) as con:
            con.execute("BEGIN IMMEDIATE")
            try:
                yield Session(self, con)
            except BaseException:
                con.execute("ROLLBACK")
                raise
            con.execute("COMMIT")

    # -- one-statement helpers ---------------------------------------------------------
    def execute(self, sql: str, args: Sequence[Any] = ()) -> Result:
        """Run one statement in its own transaction."""
        with self.session() as s:
            return s.execute(sql, args)

    def fetchall(self, sql: str, args: Sequence[Any] = ()) -> list[dict[str, Any]]:
        """The rows of one query, as dicts."""
        return self.execute(sql, args).rows

    def fetchone(self, sql: str, args: Sequence[Any] = ()) -> dict[str, Any] | None:
        """The first row of one query, or None."""
        return self.execute(sql, args).first()

    def has_table(self, name: str) -> bool:
        """Whether table ``name`` exists."""
        sql = ("SELECT 1 AS x FROM sqlite_master WHERE type = 'table' AND name = ?"
               if self.dialect == "sqlite" else "SELECT to_regclass(?) IS NOT NULL AS x")
        row = self.fetchone(sql, [name])
        return bool(row and row["x"])

    @staticmethod
    def upsert_sql(table: str, columns: Sequence[str], keys: Sequence[str]) -> str:
        """``INSERT`` of ``columns`` that updates the row already holding the same ``keys``.

        Table and column names are the caller's constants, never request text."""
        cols = ", ".join(columns)
        marks = ", ".join("?" for _ in columns)
        update = ", ".join(f"{c} = excluded.{c}" for c in columns if c not in keys)
        action = f"DO UPDATE SET {update}" if update else "DO NOTHING"
        return (f"INSERT INTO {table} ({cols}) VALUES ({marks}) "
                f"ON CONFLICT ({', '.join(keys)}) {action}")

    def close(self) -> None:
        """Close the connections kept open (also done when the Database is freed); the
        next statement opens new ones."""
        with self._kept_lock:
            _close_kept(self._kept)
            self._generation += 1
