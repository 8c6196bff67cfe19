"""Versioned schema of the catalog database: an ordered list of migrations.

Each :class:`Migration` is applied once, in order, and recorded in ``schema_version``.
Opening a catalog applies the missing ones (:func:`migrate`) under a lock, so two
processes opening a new catalog at the same moment do not both create it: PostgreSQL
takes a transaction-scoped advisory lock, SQLite a ``BEGIN IMMEDIATE`` write lock. A
migration's statements never change once released; adding a table is one new entry at
the end of :data:`MIGRATIONS`. Statements are in the dialect both servers read (TEXT,
DOUBLE PRECISION, BIGINT). A catalog created before versioning (the runs table without
``schema_version``) is adopted by migration 1's ``IF NOT EXISTS``.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timezone

from labjoint.errors import ConfigError
from labjoint.storage.sqldb import Database

#: advisory-lock key of catalog migrations (any constant 64-bit number, the same everywhere)
LOCK_KEY = 0x6C61626A6F696E74    # "labjoint"


@dataclass(frozen=True)
class Migration:
    """Schema version ``version``: ``statements`` run in one transaction."""

    version: int
    description: str
    statements: tuple[str, ...]


_RUNS = """CREATE TABLE IF NOT EXISTS runs (
    name TEXT PRIMARY KEY, path TEXT NOT NULL, uid TEXT, plan TEXT, plan_step BIGINT,
    frequency_hz DOUBLE PRECISION, excitation_vpp DOUBLE PRECISION,
    torque_nm DOUBLE PRECISION, normal_force_n DOUBLE PRECISION,
    sample_rate_hz DOUBLE PRECISION, n_samples BIGINT, status TEXT, start_time TEXT,
    start_ts DOUBLE PRECISION, end_time TEXT, source TEXT, extra TEXT)"""

#: the reprocess results (read and written by labjoint.storage.results)
_RESULTS = """CREATE TABLE IF NOT EXISTS results (
    run TEXT NOT NULL, pipeline TEXT NOT NULL, options_hash TEXT NOT NULL,
    version TEXT NOT NULL, status TEXT NOT NULL, computed_at TEXT, labjoint_version TEXT,
    input_sha256 TEXT, options TEXT, summary TEXT, error TEXT,
    PRIMARY KEY (run, pipeline, options_hash))"""

MIGRATIONS: tuple[Migration, ...] = (
    Migration(1, "runs: one row per run file", (_RUNS, *(
        f"CREATE INDEX IF NOT EXISTS runs_{c} ON runs({c})"
        for c in ("torque_nm", "excitation_vpp", "frequency_hz", "status", "start_ts", "path")))),
    Migration(2, "results: one row per (run, pipeline, options) computed by reprocess",
              (_RESULTS, "CREATE INDEX IF NOT EXISTS results_version ON results (version)",
               "CREATE INDEX IF NOT EXISTS results_pipeline ON results (pipeline, options_hash)")),
)

_VERSION_TABLE = ("CREATE TABLE IF NOT EXISTS schema_version (version BIGINT PRIMARY KEY, "
                  "description TEXT, applied_at TEXT)")


def _wal(db: Database, wait_s: float = 30.0) -> None:
    """Put a SQLite file in WAL mode (it persists in the file). Switching takes the file's
    exclusive lock and SQLite's busy handler does not wait for it, so a process opening a
    new catalog while another creates it retries for up to ``wait_s`` ("database is
    locked" otherwise failed one of four processes opening a new catalog at once)."""
    import sqlite3
    import time

    deadline = time.monotonic() + wait_s
    delay = 0.005
    while True:
        try:
            with db.session() as s:       # outside any transaction
                s.execute("PRAGMA journal_mode=WAL")
            return
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or time.monotonic() > deadline:
                raise
            time.sleep(delay)
            delay = min(2 * delay, 0.2)


def current_version(db: Database) -> int:
    """The highest applied migration (0 for an empty database)."""
    if not db.has_table("schema_version"):
        return 0
    row = db.fetchone("SELECT MAX(version) AS v FROM schema_version")
    return int(row["v"]) if row and row["v"] is not None else 0


def migrate(db: Database, migrations: tuple[Migration, ...] = MIGRATIONS) -> list[int]:
    """Apply the migrations ``db`` lacks, in order; returns their versions.

    Safe when several processes call it at once: one applies, the others wait for its
    lock and then find nothing to do. A database newer than ``migrations`` is refused
    (an older labjoint would misread it)."""
    versions = [m.version for m in migrations]
    if versions != sorted(set(versions)):
        raise ValueError(f"migration versions must increase: {versions}")
    latest = versions[-1] if versions else 0
    if db.dialect == "sqlite":
        _wal(db)
    have = current_version(db)
    if have == latest:
        return []
    applied: list[int] = []
    with db.transaction() as tx:
        if db.dialect == "postgresql":
            tx.execute("SELECT pg_advisory_xact_lock(?)", [LOCK_KEY])
        tx.execute(_VERSION_TABLE)
        done = {int(r["version"]) for r in tx.execute("SELECT version FROM schema_version").rows}
        newer = sorted(v for v in done if v > latest)
        if newer:
            raise ConfigError(f"catalog {db.label} has schema version {newer[-1]}, newer than "
                              f"this labjoint knows ({latest}): upgrade labjoint",
                              field="rig.catalog_url")
        for m in migrations:
            if m.version in done:
                continue
            for stmt in m.statements:
                tx.execute(stmt)
            tx.execute("INSERT INTO schema_version (version, description, applied_at) "
                       "VALUES (?, ?, ?)",
                       [m.version, m.description, datetime.now(timezone.utc).isoformat()])
            applied.append(m.version)
    return applied
