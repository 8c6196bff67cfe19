"""SQLite catalog of run files, so "all runs at 5 Nm between 1 and 20 Vpp" is one query.

The run files are the truth; the catalog is an index that :meth:`Catalog.rebuild`
recreates from them. WAL mode lets readers query while the daemon writes. Every
statement is parameterised; column names in filters and ordering come from a fixed
list, never from the caller's text.

>>> import tempfile, pathlib
>>> cat = Catalog(pathlib.Path(tempfile.mkdtemp()) / "catalog.db")
>>> cat.query(torque_nm=5, vpp=(1, 20))
[]
"""

from __future__ import annotations

import json
import logging
import math
import sqlite3
from contextlib import closing
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Iterable

from labjoint.errors import InputError
from labjoint.storage.layout import to_json
from labjoint.storage.reader import RunFile, open_run

log = logging.getLogger(__name__)

_COLUMNS = {
    "name": "TEXT PRIMARY KEY", "path": "TEXT NOT NULL", "uid": "TEXT", "plan": "TEXT",
    "plan_step": "", "frequency_hz": "REAL", "excitation_vpp": "REAL", "torque_nm": "REAL",
    "normal_force_n": "REAL", "sample_rate_hz": "REAL", "n_samples": "INTEGER",
    "status": "TEXT", "start_time": "TEXT", "start_ts": "REAL", "end_time": "TEXT",
    "source": "TEXT", "extra": "TEXT",
}
_NUMERIC = ("frequency_hz", "excitation_vpp", "torque_nm", "normal_force_n", "sample_rate_hz",
            "n_samples", "plan_step")
_TEXT = ("status", "plan", "source", "name", "uid")


@dataclass
class RunRecord:
    """One catalog row; ``metadata`` holds every other metadata key of the run."""

    name: str
    path: str
    uid: str = ""
    plan: str = ""
    plan_step: Any = None
    frequency_hz: float | None = None
    excitation_vpp: float | None = None
    torque_nm: float | None = None
    normal_force_n: float | None = None
    sample_rate_hz: float | None = None
    n_samples: int | None = None
    status: str = ""
    start_time: str = ""
    start_ts: float | None = None
    end_time: str = ""
    source: str = ""
    metadata: dict[str, Any] = field(default_factory=dict)


def _timestamp(value: Any, *, field: str = "start_time") -> float | None:
    """Seconds since the epoch of an ISO 8601 string, datetime or number (naive = UTC)."""
    if value is None or value == "":
        return None
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str):
        try:
            value = datetime.fromisoformat(value)
        except ValueError:
            raise InputError(f"not an ISO 8601 time: {value!r}", field=field) from None
    if isinstance(value, datetime):
        if value.tzinfo is None:
            value = value.replace(tzinfo=timezone.utc)
        return value.timestamp()
    raise InputError(f"not a time: {value!r}", field=field)


def _num(v: Any) -> float | None:
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def record_from_run(rf: RunFile) -> RunRecord:
    """The catalog record of an open run file."""
    md = dict(rf.metadata)
    rec = RunRecord(
        name=rf.name, path=str(Path(rf.path).resolve()), uid=rf.uid,
        plan=str(md.pop("plan", "") or ""), plan_step=md.pop("plan_step", None),
        frequency_hz=_num(md.pop("frequency_hz", None)),
        excitation_vpp=_num(md.pop("excitation_vpp", None)),
        torque_nm=_num(md.pop("torque_nm", None)),
        normal_force_n=_num(md.pop("normal_force_n", None)),
        sample_rate_hz=_num(md.pop("sample_rate_hz", None)),
        n_samples=rf.n_samples, status=rf.status,
        start_time=str(md.pop("start_time", "") or ""), end_time=rf.end_time,
        source=rf.source)
    for k in ("name", "uid", "status", "end_time", "n_samples", "source"):
        md.pop(k, None)
    try:
        rec.start_ts = _timestamp(rec.start_time)
    except InputError:
        rec.start_ts = None
    rec.metadata = md
    return rec


class Catalog:
    """Index of run files in an embedded SQLite database at ``db_path``."""

    def __init__(self, db_path: str | Path) -> None:
        self.db_path = Path(db_path)
        self.db_path.parent.mkdir(parents=True, exist_ok=True)
        cols = ", ".join(f"{k} {t}".strip() for k, t in _COLUMNS.items())
        with closing(self._connect()) as con, con:
            con.execute("PRAGMA journal_mode=WAL")
            con.execute(f"CREATE TABLE IF NOT EXISTS runs ({cols})")
            for c in ("torque_nm", "excitation_vpp", "frequency_hz", "status", "start_ts", "path"):
                con.execute(f"CREATE INDEX IF NOT EXISTS runs_{c} ON runs({c})")

    def _connect(self) -> sqlite3.Connection:
        try:
            con = sqlite3.connect(self.db_path, timeout=30.0)
        except sqlite3.Error as exc:
            raise InputError(f"cannot open catalog: {exc}", file=str(self.db_path)) from None
        con.row_factory = sqlite3.Row
        con.execute("PRAGMA synchronous=NORMAL")  # WAL: durable enough for a rebuildable index
        return con

    # -- writing -----------------------------------------------------------------
    def put(self, rec: RunRecord, con: sqlite3.Connection | None = None) -> None:
        """Insert the row of ``rec.name``, or update it when it is the same run file; a
        different file under a name the catalog holds is refused, never replaced."""
        row = {k: getattr(rec, k) for k in _COLUMNS if k != "extra"}
        self._check_name(rec, con)
        row["extra"] = to_json(rec.metadata)
        sql = (f"INSERT OR REPLACE INTO runs ({', '.join(row)}) "
               f"VALUES ({', '.join('?' for _ in row)})")
        if con is not None:
            con.execute(sql, list(row.values()))
            return
        with closing(self._connect()) as c, c:
            c.execute(sql, list(row.values()))

    def _check_name(self, rec: RunRecord, con: sqlite3.Connection | None) -> None:
        sql = "SELECT path, uid FROM runs WHERE name = ?"
        if con is not None:
            old = con.execute(sql, (rec.name,)).fetchone()
        else:
            with closing(self._connect()) as c:
                old = c.execute(sql, (rec.name,)).fetchone()
        if old is None or (old["uid"] and old["uid"] == rec.uid):
            return
        self._refuse_other(rec.name, old["path"], rec.path)

    def check_free(self, name: str, path: str | Path) -> None:
        """Refuse to store a run called ``name`` at ``path`` when the catalog holds another
        existing file under that name (call before writing, so nothing is half-stored)."""
        old = self.get(name)
        if old is not None:
            self._refuse_other(name, old.path, path)

    @staticmethod
    def _refuse_other(name: str, old_path: str, new_path: str | Path) -> None:
        if Path(old_path).resolve() == Path(new_path).resolve() or not Path(old_path).exists():
            return       # the same file re-indexed, or the catalogued file is gone (stale row)
        raise InputError(f"the catalog already holds a run named {name!r} (file {old_path}); "
                         "rename one of them", file=str(new_path), field="name")

    def add(self, path: str | Path) -> RunRecord:
        """Index (or re-index) the run file at ``path``."""
        with open_run(path) as rf:
            rec = record_from_run(rf)
        self.put(rec)
        return rec

    update = add

    def remove(self, name: str) -> bool:
        """Drop a run from the index (the file stays); True if it was there."""
        with closing(self._connect()) as con, con:
            return con.execute("DELETE FROM runs WHERE name = ?", (name,)).rowcount > 0

    def rebuild(self, data_dir: str | Path) -> int:
        """Re-create the index from every ``*.h5`` run file in ``data_dir``; returns the count.

        Files that are not readable run files are skipped (and logged)."""
        recs = []
        for p in sorted(Path(data_dir).glob("*.h5")):
            try:
                with open_run(p) as rf:
                    recs.append(record_from_run(rf))
            except InputError as exc:
                log.warning("catalog rebuild: skipping %s: %s", p, exc)
        with closing(self._connect()) as con, con:
            con.execute("DELETE FROM runs")
            for rec in recs:
                self.put(rec, con)
        return len(recs)

    # -- reading -----------------------------------------------------------------
    def get(self, name: str) -> RunRecord | None:
        """The record of run ``name``, or None."""
        rows = self._select("SELECT * FROM runs WHERE name = ?", [name])
        return rows[0] if rows else None

    def query(self, *, torque_nm: Any = None, vpp: Any = None, excitation_vpp: Any = None,
              frequency_hz: Any = None, normal_force_n: Any = None, sample_rate_hz: Any = None,
              n_samples: Any = None, plan_step: Any = None, status: Any = None,
              plan: Any = None, source: Any = None, name: Any = None,
              since: Any = None, until: Any = None, search: str | None = None,
              limit: int | None = None, offset: int = 0,
              order: str = "start_time") -> list[RunRecord]:
        """Runs matching every filter given, in one SQL query.

        Numeric filters take a value (matched to 1e-9 relative) or an inclusive range
        ``(lo, hi)`` with None for an open end; ``vpp`` is ``excitation_vpp``. Text
        filters take a value or a list of values; ``search`` is a case-insensitive part
        of the name. ``since``/``until`` bound the start time (ISO 8601, datetime or
        epoch seconds). ``order`` is a column name, with a leading "-" for descending.
        """
        where, args = self._where(torque_nm=torque_nm, vpp=vpp, excitation_vpp=excitation_vpp,
                                  frequency_hz=frequency_hz, normal_force_n=normal_force_n,
                                  sample_rate_hz=sample_rate_hz, n_samples=n_samples,
                                  plan_step=plan_step, status=status, plan=plan, source=source,
                                  name=name, since=since, until=until, search=search)
        sql = "SELECT * FROM runs" + (" WHERE " + " AND ".join(where) if where else "")
        desc = order.startswith("-")
        col = order.lstrip("-")
        if col not in _COLUMNS or col == "extra":
            raise InputError(f"cannot order by {order!r}; columns: {list(_COLUMNS)[:-1]}", field="order")
        sql += f" ORDER BY {col} {'DESC' if desc else 'ASC'}, name ASC"
        if limit is not None:
            if int(limit) < 0 or int(offset) < 0:
                raise InputError("limit and offset must be >= 0", field="limit")
            sql += " LIMIT ? OFFSET ?"
            args += [int(limit), int(offset)]
        elif offset:
            sql += " LIMIT -1 OFFSET ?"
            args.append(int(offset))
        return self._select(sql, args)

    def count(self, **filters: Any) -> int:
        """How many runs match ``filters`` (those of :meth:`query`)."""
        where, args = self._where(**filters)
        sql = "SELECT COUNT(*) FROM runs" + (" WHERE " + " AND ".join(where) if where else "")
        with closing(self._connect()) as con:
            return int(con.execute(sql, args).fetchone()[0])

    @staticmethod
    def _where(*, torque_nm: Any = None, vpp: Any = None, excitation_vpp: Any = None,
               frequency_hz: Any = None, normal_force_n: Any = None, sample_rate_hz: Any = None,
               n_samples: Any = None, plan_step: Any = None, status: Any = None,
               plan: Any = None, source: Any = None, name: Any = None, since: Any = None,
               until: Any = None, search: str | None = None) -> tuple[list[str], list[Any]]:
        """The WHERE terms and their arguments of :meth:`query`'s filters."""
        if vpp is not None and excitation_vpp is not None:
            raise InputError("give vpp or excitation_vpp, not both", field="vpp")
        where: list[str] = []
        args: list[Any] = []
        numeric = dict(torque_nm=torque_nm, excitation_vpp=vpp if vpp is not None else excitation_vpp,
                       frequency_hz=frequency_hz, normal_force_n=normal_force_n,
                       sample_rate_hz=sample_rate_hz, n_samples=n_samples, plan_step=plan_step)
        for col, v in numeric.items():
            if v is not None:
                _numeric_filter(col, v, where, args)
        for col, v in dict(status=status, plan=plan, source=source, name=name).items():
            if v is None:
                continue
            vals = [v] if isinstance(v, str) else list(v)
            where.append(f"{col} IN ({', '.join('?' for _ in vals)})")
            args.extend(str(x) for x in vals)
        if since is not None:
            where.append("start_ts >= ?")
            args.append(_timestamp(since, field="since"))
        if until is not None:
            where.append("start_ts <= ?")
            args.append(_timestamp(until, field="until"))
        if search:
            pattern = str(search).replace("\\", "\\\\").replace("%", "\\%").replace("_", "\\_")
            where.append("name LIKE ? ESCAPE '\\'")       # LIKE ignores ASCII case
            args.append(f"%{pattern}%")
        return where, args

    def __len__(self) -> int:
        with closing(self._connect()) as con:
            return int(con.execute("SELECT COUNT(*) FROM runs").fetchone()[0])

    def _select(self, sql: str, args: Iterable[Any]) -> list[RunRecord]:
        with closing(self._connect()) as con:
            rows = con.execute(sql, list(args)).fetchall()
        out = []
        for r in rows:
            d = {k: r[k] for k in r.keys() if k != "extra"}
            d["metadata"] = json.loads(r["extra"]) if r["extra"] else {}
            out.append(RunRecord(**d))
        return out


def _numeric_filter(col: str, v: Any, where: list[str], args: list[Any]) -> None:
    if isinstance(v, (tuple, list)):
        if len(v) != 2:
            raise InputError(f"range must be (lo, hi), got {v!r}", field=col)
        lo, hi = v
        if lo is not None:
            where.append(f"{col} >= ?")
            args.append(_check_num(lo, col))
        if hi is not None:
            where.append(f"{col} <= ?")
            args.append(_check_num(hi, col))
        return
    x = _check_num(v, col)
    tol = 1e-9 * max(1.0, abs(x))
    where.append(f"{col} BETWEEN ? AND ?")
    args += [x - tol, x + tol]


def _check_num(v: Any, col: str) -> float:
    x = _num(v)
    if x is None:
        raise InputError(f"not a finite number: {v!r}", field=col)
    return x
