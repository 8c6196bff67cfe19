"""From a run name in a request to a file: through the catalog, never by joining strings.

A request names a run; the name must match :data:`~labjoint.api.schemas.RUN_NAME`
(no separators, no leading dot), is looked up in the catalog, and the catalog's path
is resolved (symlinks followed) and must lie inside the data directory. Nothing a
client sends is ever used to build a path.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from labjoint.api.errors import ApiError, not_found
from labjoint.api.schemas import RUN_NAME
from labjoint.storage import Catalog, RunFile, RunRecord, open_run
from labjoint.storage.catalog import record_from_row
from labjoint.storage.roles import channel_roles

_NAME = re.compile(RUN_NAME)


class RunResolver:
    """Catalog lookups and safe paths for runs in ``data_dir``.

    Single-run lookups (the hot path of the API) go through one read-only connection
    per thread, kept open (:meth:`~labjoint.storage.sqldb.Database.reader`): opening and
    closing a SQLite connection per request (what :meth:`Catalog.get` does) costs several
    times the query itself.
    """

    def __init__(self, data_dir: str | Path, catalog: Catalog) -> None:
        self.data_dir = Path(data_dir).resolve()
        self.catalog = catalog

    def record(self, name: str) -> RunRecord:
        """The catalog record of ``name`` (422 for a malformed name, 404 if unknown)."""
        if not isinstance(name, str) or not _NAME.match(name):
            raise ApiError(422, "invalid_run_name", f"run name {name!r} must match {RUN_NAME}")
        with self.catalog.sql.reader() as s:
            row = s.execute("SELECT * FROM runs WHERE name = ?", [name]).first()
        if row is None:
            raise not_found("run", name)
        return record_from_row(row)

    def path(self, name: str) -> Path:
        """The run file of ``name``, verified to be inside the data directory."""
        rec = self.record(name)
        p = Path(rec.path)
        if not p.is_absolute():
            p = self.data_dir / p
        p = p.resolve()
        if not p.is_relative_to(self.data_dir):
            raise ApiError(403, "outside_data_dir", f"run {name!r} is catalogued at a path "
                           "outside the data directory; it is not served")
        if not p.is_file():
            raise ApiError(404, "file_missing", f"run {name!r} is in the catalog but its file "
                           "is gone (`labjoint recover` brings the catalog in line with the files)")
        return p

    def open(self, name: str) -> RunFile:
        """The run file opened for reading (close it)."""
        return open_run(self.path(name))


def find_named(data_dir: str | Path, folder: str, name: str, suffix: str) -> Path | None:
    """The file ``<name><suffix>`` among the data directory's ``folder`` (looked up among
    its files: nothing a client sends is joined into a path), or None."""
    base = Path(data_dir) / folder
    if base.is_dir():
        for p in base.iterdir():
            if p.is_file() and p.suffix == suffix and p.stem == name:
                return p.resolve()
    return None


def roles(rf: RunFile) -> dict[str, Any]:
    """Channels holding the relative displacement and the joint/reference force
    (:mod:`labjoint.storage.roles`); a role with no channel present is empty."""
    return channel_roles(rf.metadata, rf.channel_names).present
