"""The checksum of what a run measured: every object of the run file but its results.

A file's own sha256 changes whenever a result is stored in it (``/entry/processed``), so
it cannot trace a published number to its data. :func:`raw_sha256` hashes, in a fixed
order, every group and dataset under ``/entry`` except ``/entry/processed``: names,
attributes, and each dataset's dtype, shape and stored bytes (chunk by chunk as written,
compressed, read straight from the file: never the whole record in memory, nothing
decompressed). A copy rewritten with other filters (h5repack) has another checksum. Storing or replacing results leaves it unchanged; changing one
sample, a sensitivity or a metadata value changes it.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import BinaryIO

import h5py
import numpy as np

from labjoint.errors import InputError
from labjoint.storage.h5open import H5_FILE_ERRORS

#: elements hashed at a time along a dataset's first axis
SLICE_ELEMENTS = 1 << 20
EXCLUDED = ("entry/processed",)


def _attrs(h: "hashlib._Hash", obj: h5py.HLObject) -> None:
    for key in sorted(obj.attrs):
        value = np.asarray(obj.attrs[key])
        h.update(f"@{key}:{value.dtype.str}:{value.shape}".encode())
        h.update(value.tobytes() if value.dtype.kind != "O" else repr(value.tolist()).encode())


def _dataset(h: "hashlib._Hash", ds: h5py.Dataset, raw: BinaryIO) -> None:
    h.update(f"{ds.dtype.str}:{ds.shape}".encode())
    if ds.shape is None or ds.size == 0:
        return
    dsid = ds.id
    if ds.chunks is not None:
        # the stored (compressed) bytes of every chunk, read straight from the file: no
        # decompression, the same bytes for the same data and filters
        infos = sorted((dsid.get_chunk_info(i) for i in range(dsid.get_num_chunks())),
                       key=lambda c: c.chunk_offset)
        for c in infos:
            h.update(f"{c.chunk_offset}:{c.filter_mask}:{c.size}".encode())
            raw.seek(c.byte_offset)
            h.update(raw.read(c.size))
        return
    offset = dsid.get_offset()
    if offset is not None and ds.dtype.kind != "O":
        raw.seek(offset)
        h.update(raw.read(dsid.get_storage_size()))
        return
    if ds.ndim == 0 or ds.dtype.kind == "O":
        h.update(repr(np.asarray(ds[()]).tolist()).encode())
        return
    row = max(1, int(np.prod(ds.shape[1:], dtype=np.int64)))
    step = max(1, SLICE_ELEMENTS // row)
    for a in range(0, ds.shape[0], step):
        h.update(np.ascontiguousarray(ds[a:a + step]).tobytes())


def raw_sha256(path: str | Path) -> str:
    """sha256 of the run file's measurement (everything under /entry but its results)."""
    p = Path(path)
    h = hashlib.sha256()
    try:
        with h5py.File(p, "r", locking=False) as f, open(p, "rb") as raw:
            if "entry" not in f:
                raise InputError("not a labjoint run file (no /entry)", file=str(p))
            names: list[str] = []
            f["entry"].visit(lambda n: names.append("entry/" + n))
            _attrs(h, f["entry"])
            for name in sorted(names):
                if any(name == x or name.startswith(x + "/") for x in EXCLUDED):
                    continue
                obj = f[name]
                h.update(f"\n{name}\n".encode())
                _attrs(h, obj)
                if isinstance(obj, h5py.Dataset):
                    _dataset(h, obj, raw)
    except FileNotFoundError:
        raise InputError("run file disappeared (no such file)", file=str(p)) from None
    except InputError:                # (a ValueError too) already names the file
        raise
    except H5_FILE_ERRORS as exc:     # garbage in the header: RuntimeError from h5py
        raise InputError(f"not a readable HDF5 run file: {exc}", file=str(p)) from None
    return h.hexdigest()
