"""Catalog of run files, so "all runs at 5 Nm between 1 and 20 Vpp" is one query.

The run files are the truth; the catalog is an index that :meth:`Catalog.rebuild`
recreates from them and :meth:`Catalog.sync` (``labjoint recover``) brings in line. It lives in an embedded SQLite file (WAL mode lets readers query
while the daemon writes) or, for several machines sharing one archive, in PostgreSQL
(``catalog_url`` in the config; :func:`catalog_for`). All SQL goes through
:class:`~labjoint.storage.sqldb.Database`; the schema is versioned
(:mod:`labjoint.storage.migrations`). Every statement is parameterised; column names in
filters and ordering come from a fixed list, never from the caller's text.

>>> import tempfile, pathlib
>>> cat = Catalog(pathlib.Path(tempfile.mkdtemp()) / "catalog.db")
>>> cat.query(torque_nm=5, vpp=(1, 20))
[]
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Iterator

from labjoint.errors import ConfigError, InputError
from labjoint.storage.h5open import run_identity
from labjoint.storage.layout import to_json
from labjoint.storage.migrations import migrate
from labjoint.storage.sqldb import Database, Session, is_postgres_url, redact_url

if TYPE_CHECKING:
    from labjoint.config import RigConfig
from labjoint.storage.reader import open_run
from labjoint.storage.run_record import (RunRecord, _num, _timestamp, record_from_row,
                                         record_from_run)

log = logging.getLogger(__name__)

#: the runs table's columns (schema: migration 1 of labjoint.storage.migrations)
_COLUMNS = ("name", "path", "uid", "plan", "plan_step", "frequency_hz", "excitation_vpp",
            "torque_nm", "normal_force_n", "sample_rate_hz", "n_samples", "status",
            "start_time", "start_ts", "end_time", "source", "extra")
#: the file name of the embedded catalog in a data directory
CATALOG_FILE = "catalog.sqlite"
_NUMERIC = ("frequency_hz", "excitation_vpp", "torque_nm", "normal_force_n", "sample_rate_hz",
            "n_samples", "plan_step")
_TEXT = ("status", "plan", "source", "name", "uid")


class Catalog:
    """Index of run files in a SQLite file (a path) or PostgreSQL (a ``postgresql://`` URL).

    Opening it applies the schema migrations the database lacks. Other modules that keep
    their own tables in the catalog database (migrations add them) run their SQL
    through :attr:`sql`, the same :class:`~labjoint.storage.sqldb.Database`.
    """

    def __init__(self, target: str | Path) -> None:
        self.sql = Database(target)
        #: the SQLite file, None for a PostgreSQL catalog
        self.db_path = self.sql.path
        self.location = self.sql.label
        migrate(self.sql)

    def __repr__(self) -> str:
        return f"Catalog({self.location!r})"

    def close(self) -> None:
        """Close the database connections kept open (reopened on the next use)."""
        self.sql.close()

    # -- writing -----------------------------------------------------------------
    def put(self, rec: RunRecord, con: Session | None = None) -> None:
        """Insert the row of ``rec.name``, or update it when it is the same run file; a
        different file under a name the catalog holds is refused, never replaced."""
        row: dict[str, Any] = {k: getattr(rec, k) for k in _COLUMNS if k != "extra"}
        md = dict(rec.metadata)
        step = _step(rec.plan_step)
        if step is None and rec.plan_step is not None:
            md.setdefault("plan_step", rec.plan_step)    # not a step number: kept, as metadata
        row["plan_step"] = step
        row["extra"] = to_json(md)
        sql = self.sql.upsert_sql("runs", list(row), ["name"])
        if con is not None:
            self._check_name(rec, con)
            con.execute(sql, list(row.values()))
            return
        with self.sql.transaction() as tx:
            self._check_name(rec, tx)
            tx.execute(sql, list(row.values()))

    def _check_name(self, rec: RunRecord, con: Session) -> None:
        con.lock(f"runs:{rec.name}")       # two machines adding one name: the second sees the first
        old = con.execute("SELECT path, uid FROM runs WHERE name = ?", [rec.name]).first()
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
        return self.sql.execute("DELETE FROM runs WHERE name = ?", [name]).rowcount > 0

    def rebuild(self, data_dir: str | Path) -> int:
        """Re-create the index of the runs in ``data_dir`` from its ``*.h5`` run files;
        returns their count. Runs catalogued in other directories (other machines' on a
        shared catalog) are kept. Files that are not readable run files are skipped
        (and logged)."""
        recs = []
        for p, rec in _read_dir(Path(data_dir)):
            if isinstance(rec, InputError):
                log.warning("catalog rebuild: skipping %s: %s", p, rec)
            else:
                recs.append(rec)
        with self.sql.transaction() as tx:
            for row in _rows_in(tx.execute("SELECT name, path FROM runs").rows, data_dir):
                tx.execute("DELETE FROM runs WHERE name = ?", [row["name"]])
            for rec in recs:
                self.put(rec, tx)
        return len(recs)

    def sync(self, data_dir: str | Path) -> dict[str, Any]:
        """Bring the index of ``data_dir`` in line with its files: index the run files it
        lacks, drop the runs whose files are gone; other directories are left alone.

        A file holding the same run (name and uid) as a catalogued file that exists is a
        copy: it is not indexed, and listed under its run's name in "copies" (checked
        from the two identifiers alone, so a directory of 1,000 copies syncs in seconds
        and the same copies are never "added" again on the next sync). Returns
        {"added": names, "removed": names, "skipped": {file: why}, "copies": {name: files}}."""
        rows = self.sql.fetchall("SELECT name, path, uid FROM runs")
        out: dict[str, Any] = {"added": [], "removed": [], "skipped": {}, "copies": {}}
        for row in _rows_in(rows, data_dir):
            if not Path(row["path"]).exists() and self.remove(row["name"]):
                out["removed"].append(row["name"])
        held = {r["name"]: (Path(r["path"]), r["uid"]) for r in rows
                if r["name"] not in out["removed"]}
        known = {Path(r["path"]).resolve() for r in rows}
        recs: list[RunRecord] = []
        for p in sorted(Path(data_dir).glob("*.h5")):
            if not p.is_file():              # before resolve(): a symlink loop raises there
                out["skipped"][str(p)] = "not a file (a directory, a broken link or a link loop)"
                continue
            if p.resolve() in known:
                continue
            try:
                name, uid = run_identity(p)
                old = held.get(name)
                if old is not None and old[1] == uid and old[0].resolve() != p.resolve() \
                        and old[0].exists():
                    out["copies"].setdefault(name, []).append(str(p))
                    continue
                with open_run(p) as rf:
                    rec = record_from_run(rf)
            except InputError as exc:
                out["skipped"][str(p)] = exc.message
                continue
            recs.append(rec)
            held.setdefault(rec.name, (p, rec.uid))      # later copies in this pass
        with self.sql.transaction() as tx:             # one commit for all of them
            for rec in recs:
                try:
                    self.put(rec, tx)                  # refused if another file holds the name
                except InputError as exc:
                    out["skipped"][rec.path] = exc.message
                    continue
                out["added"].append(rec.name)
        return out

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
            if int(offset) < 0:
                raise InputError("limit and offset must be >= 0", field="offset")
            sql += " LIMIT ? OFFSET ?"             # no "LIMIT -1"/"LIMIT ALL" both read
            args += [_NO_LIMIT, int(offset)]
        return self._select(sql, args)

    def count(self, **filters: Any) -> int:
        """How many runs match ``filters`` (those of :meth:`query`)."""
        where, args = self._where(**filters)
        sql = "SELECT COUNT(*) AS n FROM runs" + (" WHERE " + " AND ".join(where) if where else "")
        return int(self.sql.fetchone(sql, args)["n"])

    def _where(self, *, torque_nm: Any = None, vpp: Any = None, excitation_vpp: Any = None,
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
            where.append(f"name {self.sql.like_ci} ? ESCAPE '\\'")   # ignoring ASCII case
            args.append(f"%{pattern}%")
        return where, args

    def __len__(self) -> int:
        return int(self.sql.fetchone("SELECT COUNT(*) AS n FROM runs")["n"])

    def _select(self, sql: str, args: Iterable[Any]) -> list[RunRecord]:
        return [record_from_row(r) for r in self.sql.fetchall(sql, list(args))]


def _read_dir(d: Path, skip: set[Path] = frozenset()
              ) -> Iterator[tuple[Path, RunRecord | InputError]]:
    """Each ``*.h5`` file of ``d`` not in ``skip``, with its record or why it has none."""
    for p in sorted(d.glob("*.h5")):
        if not p.is_file():
            yield p, InputError("not a file (a directory, a broken link or a link loop)",
                                file=str(p))
            continue
        if p.resolve() in skip:
            continue
        try:
            with open_run(p) as rf:
                rec: RunRecord | InputError = record_from_run(rf)
        except InputError as exc:
            rec = exc
        yield p, rec


def _rows_in(rows: list[dict[str, Any]], data_dir: str | Path) -> list[dict[str, Any]]:
    """The (name, path) rows of runs catalogued at files directly in ``data_dir``."""
    d = Path(data_dir).resolve()
    return [r for r in rows if Path(r["path"]).parent.resolve() == d]


def _step(v: Any) -> int | None:
    """A plan step as the integer column holds it; None if it is not a whole number."""
    if v is None or isinstance(v, bool):
        return None
    x = _num(v)
    return int(x) if x is not None and x == int(x) and abs(x) < 2**62 else None


#: "no limit" for a query with only an offset (the largest BIGINT)
_NO_LIMIT = 2**63 - 1


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


def open_catalog(data_dir: str | Path, url: str = "") -> Catalog:
    """The catalog of ``data_dir``: the PostgreSQL database at ``url`` when given, else
    the embedded SQLite file ``data_dir/catalog.sqlite``."""
    if url:
        if not is_postgres_url(url):
            raise ConfigError(f"not a postgresql:// URL: {redact_url(url)!r}",
                              field="rig.catalog_url")
        return Catalog(url)
    return Catalog(Path(data_dir) / CATALOG_FILE)


def catalog_for(config: RigConfig | None, data_dir: str | Path | None = None) -> Catalog:
    """The catalog a rig config names (``[rig] catalog_url``, default: the SQLite file in
    ``data_dir``, itself defaulting to the config's ``data_dir``)."""
    rig = config.rig if config is not None else None
    d = data_dir if data_dir is not None else (rig.data_dir if rig is not None else "data")
    return open_catalog(d, rig.catalog_url if rig is not None else "")
