"""Processed results beside the raw data: ``/entry/processed/<name>`` (NXprocess).

Raw data are never touched: the only path written is ``/entry/processed/<name>``
with ``name`` a plain identifier. A group is first written under a hidden name and
then swapped in, so an earlier result of the same name is replaced in one step.
HDF5 does not reclaim the space of a replaced group (``h5repack`` does).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Mapping

import h5py
import numpy as np

from labjoint import __version__
from labjoint.errors import InputError
from labjoint.storage import layout
from labjoint.storage.h5open import H5_FILE_ERRORS
from labjoint.storage.reader import open_run
from labjoint.storage.writer import OPEN_FOR_WRITE, utc_now

_GROUP_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,63}$")
_RESERVED = ("program", "version", "date")


def _put(g: h5py.Group, arrays: Mapping[str, Any], units: Mapping[str, Any], where: str) -> None:
    for key, value in arrays.items():
        if not _GROUP_RE.match(str(key)):
            raise InputError(f"array name {key!r} must be an identifier", field=f"{where}{key}")
        if isinstance(value, Mapping):
            sub = g.create_group(key)
            sub.attrs["NX_class"] = "NXcollection"
            u = units.get(key, {})
            _put(sub, value, u if isinstance(u, Mapping) else {}, f"{where}{key}.")
            continue
        if isinstance(value, str):
            ds = g.create_dataset(key, data=value, dtype=h5py.string_dtype())
        else:
            arr = np.asarray(value)
            if arr.dtype.kind not in "biufc":
                raise InputError(f"array {key!r} must be numeric or str, got {arr.dtype}",
                                 field=f"{where}{key}")
            ds = g.create_dataset(key, data=arr)
        unit = units.get(key, "")
        ds.attrs["units"] = "" if isinstance(unit, Mapping) else str(unit)


@layout.locked
def write_processed(path: str | Path, group_name: str, arrays: Mapping[str, Any],
                    attrs: Mapping[str, Any] | None = None,
                    units: Mapping[str, Any] | None = None) -> None:
    """Write ``arrays`` (name -> array, str or nested mapping) to ``/entry/processed/<group_name>``.

    ``units`` gives each array's ``@units`` (SI; "" for none, the default). ``attrs``
    are JSON-able scalars, strings or lists (dicts are stored as JSON text).
    An earlier group of the same name is replaced; nothing else in the file changes.
    """
    p = Path(path)
    if not _GROUP_RE.match(str(group_name)):
        raise InputError(f"processed group name {group_name!r} must be an identifier "
                         "(letters, digits, underscore)", field="group_name")
    clash = [k for k in arrays if k in _RESERVED]
    if clash:
        raise InputError(f"array names {clash} are reserved for NXprocess fields",
                         field=f"{group_name}.{clash[0]}")
    if str(p.resolve()) in OPEN_FOR_WRITE:
        raise InputError("run is still being written", file=str(p))
    try:
        f = h5py.File(p, "r+")
    except FileNotFoundError:
        raise InputError("no such run file", file=str(p)) from None
    except H5_FILE_ERRORS as exc:
        raise InputError(f"cannot open run file for writing ({exc}); if its writer died, "
                         "`labjoint recover` clears its flags", file=str(p)) from None
    with f:
        try:
            root = f.get("entry/processed")
        except H5_FILE_ERRORS as exc:
            raise InputError(f"damaged run file: {exc}", file=str(p)) from None
        if root is None:
            raise InputError("not a labjoint run file (no /entry/processed)", file=str(p))
        tmp_name, old_name = f".{group_name}.new", f".{group_name}.old"
        for n in (tmp_name, old_name):
            if n in root:
                del root[n]
        g = root.create_group(tmp_name)
        g.attrs["NX_class"] = "NXprocess"
        layout.text(g, "program", "labjoint")
        layout.text(g, "version", __version__)
        layout.text(g, "date", utc_now())
        try:
            for k, v in (attrs or {}).items():
                if isinstance(v, Mapping):
                    v = layout.to_json(v, field=f"attrs.{k}")
                elif v is None:
                    v = "null"
                try:
                    g.attrs[str(k)] = v
                except (TypeError, ValueError) as exc:
                    raise InputError(f"attribute cannot be stored: {exc}",
                                     field=f"{group_name}.attrs.{k}") from None
            _put(g, arrays, units or {}, f"{group_name}.")
        except BaseException:
            del root[tmp_name]
            raise
        if group_name in root:
            root.move(group_name, old_name)
        root.move(tmp_name, group_name)
        if old_name in root:
            del root[old_name]


@layout.locked
def read_processed(path: str | Path, group_name: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """Arrays and attributes of a processed group (see :meth:`RunFile.processed`)."""
    with open_run(path) as rf:
        return rf.processed(group_name)
