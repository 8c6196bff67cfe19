"""The catalog's ``results`` table: which pipeline result of which run, by which code.

A result is keyed by (run, pipeline, options hash) and records the pipeline version
(a content hash of the code and settings that produce it, :mod:`labjoint.batch.pipelines`),
the labjoint version, the options (JSON), the sha256 of the run's measurement
(:func:`labjoint.storage.checksum.raw_sha256`, unchanged when results are stored in the
file), its status (``complete`` or ``failed``), when it was computed, a small JSON
summary and the error of a failed run. The processed arrays themselves live in the run file
(``/entry/processed/<name>``); this table is what a reprocess plans from without opening a
single run file.

The table lives in the catalog's database, created by the catalog's migration 2
(:mod:`labjoint.storage.migrations`), and is read and written through the catalog's SQL
adapter (``catalog.sql``) in portable SQL, so the same statements serve SQLite and the
shared PostgreSQL catalog.

>>> import tempfile, pathlib
>>> from labjoint.storage.catalog import Catalog
>>> res = Results(Catalog(pathlib.Path(tempfile.mkdtemp()) / "catalog.sqlite"))
>>> res.record(ResultRow("r1", "analyze", "h1", "v1", "complete", summary={"cycles": 9}))
>>> res.get("r1", "analyze", "h1").summary
{'cycles': 9}
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field
from typing import Any, Iterable

from labjoint import __version__
from labjoint.documents import utc_now
from labjoint.errors import InputError

STATUSES = ("complete", "failed")

COLUMNS = ("run", "pipeline", "options_hash", "version", "status", "computed_at",
           "labjoint_version", "input_sha256", "options", "summary", "error")
_KEY = ("run", "pipeline", "options_hash")

def options_json(options: dict[str, Any]) -> str:
    """Canonical JSON of pipeline options (sorted keys, no spaces): what is hashed and stored.

    >>> options_json({"b": 1, "a": [2, 3]})
    '{"a":[2,3],"b":1}'
    """
    try:
        return json.dumps(options, sort_keys=True, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise InputError(f"options must be JSON (finite numbers, strings, lists): {exc}",
                         field="options") from None


def options_hash(options: dict[str, Any]) -> str:
    """The first 16 hex digits of the sha256 of :func:`options_json`.

    >>> options_hash({}) == options_hash({}) and len(options_hash({"a": 1}))
    16
    """
    return hashlib.sha256(options_json(options).encode()).hexdigest()[:16]


@dataclass
class ResultRow:
    """One row of ``results``; ``options`` and ``summary`` are JSON-able dicts."""

    run: str
    pipeline: str
    options_hash: str
    version: str
    status: str
    computed_at: str = ""
    labjoint_version: str = __version__
    input_sha256: str = ""
    options: dict[str, Any] = field(default_factory=dict)
    summary: dict[str, Any] = field(default_factory=dict)
    error: str = ""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class Results:
    """The ``results`` table in the database of a :class:`~labjoint.storage.catalog.Catalog`."""

    def __init__(self, catalog: Any) -> None:
        self.db = catalog.sql           # the table itself is migration 2 of the catalog

    def record(self, row: ResultRow) -> None:
        """Insert or replace the row of (run, pipeline, options_hash)."""
        if row.status not in STATUSES:
            raise InputError(f"status must be one of {STATUSES}, got {row.status!r}",
                             field="status")
        vals = row.to_dict()
        vals["computed_at"] = vals["computed_at"] or utc_now()
        vals["options"] = options_json(row.options)
        vals["summary"] = json.dumps(_finite(row.summary), sort_keys=True, default=_jsonable,
                                     allow_nan=False)
        sets = ", ".join(f"{c} = excluded.{c}" for c in COLUMNS if c not in _KEY)
        sql = (f"INSERT INTO results ({', '.join(COLUMNS)}) "
               f"VALUES ({', '.join('?' for _ in COLUMNS)}) "
               f"ON CONFLICT ({', '.join(_KEY)}) DO UPDATE SET {sets}")
        self.db.execute(sql, [vals[c] for c in COLUMNS])

    def get(self, run: str, pipeline: str, options_hash: str) -> ResultRow | None:
        rows = self._select("SELECT * FROM results WHERE run = ? AND pipeline = ? "
                            "AND options_hash = ?", [run, pipeline, options_hash])
        return rows[0] if rows else None

    def of(self, pipeline: str, options_hash: str) -> dict[str, tuple[str, str]]:
        """run -> (status, version) of every result of ``pipeline`` with these options, in
        one query (what a reprocess plans from)."""
        rows = self.db.fetchall("SELECT run, status, version FROM results WHERE pipeline = ? "
                                "AND options_hash = ?", [pipeline, options_hash])
        return {r["run"]: (r["status"], r["version"]) for r in rows}

    def runs_with_version(self, version: str, status: str = "complete") -> set[str]:
        """Names of the runs holding a result of pipeline version ``version``."""
        rows = self.db.fetchall("SELECT DISTINCT run FROM results WHERE version = ? "
                                "AND status = ?", [version, status])
        return {r["run"] for r in rows}

    def for_runs(self, runs: Iterable[str]) -> dict[str, list[ResultRow]]:
        """run -> its result rows, for the named runs."""
        names = list(dict.fromkeys(runs))
        out: dict[str, list[ResultRow]] = {n: [] for n in names}
        for a in range(0, len(names), 500):           # bounded IN lists
            part = names[a:a + 500]
            for r in self._select(f"SELECT * FROM results WHERE run IN "
                                  f"({', '.join('?' for _ in part)}) "
                                  "ORDER BY run, pipeline, options_hash", part):
                out[r.run].append(r)
        return out

    def _select(self, sql: str, args: list[Any]) -> list[ResultRow]:
        out = []
        for r in self.db.fetchall(sql, args):
            d = {c: r[c] for c in COLUMNS}
            d["options"] = json.loads(d["options"]) if d["options"] else {}
            d["summary"] = json.loads(d["summary"]) if d["summary"] else {}
            d["error"] = d["error"] or ""
            out.append(ResultRow(**d))
        return out


def _finite(obj: Any) -> Any:
    """NaN and infinities as None, so the stored summary is strict JSON.

    >>> _finite({"a": [1.0, float("nan")], "b": float("inf")})
    {'a': [1.0, None], 'b': None}
    """
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if hasattr(obj, "item") and callable(obj.item) and getattr(obj, "ndim", 1) == 0:
        return _finite(obj.item())
    return obj


def _jsonable(obj: Any) -> Any:
    """numpy scalars and arrays in a summary as plain numbers and lists."""
    for attr in ("item", "tolist"):
        f = getattr(obj, attr, None)
        if callable(f):
            return f()
    raise TypeError(f"not JSON-able: {type(obj).__name__}")
