"""Opening run files at the file boundary: what a damaged file raises, and a SWMR read
that gives up on bad metadata instead of waiting for a writer that will never fix it.

h5py raises OSError, RuntimeError ("Can't decode fractal heap header prefix" for garbage
in a file's header area), KeyError, ValueError or TypeError on a damaged file:
:data:`H5_FILE_ERRORS` is that family, caught where a file is opened and turned into
an InputError naming the file.

A SWMR reader retries a metadata read whose checksum fails, expecting the writer to
finish the block; HDF5's default is 100 attempts with a sleep doubling from 1 ns (capped
at an hour), so on a corrupt file whose writer is gone it sleeps for hours. The
``labjoint-swmr`` driver (the sec2 driver with ``H5Pset_metadata_read_attempts``,
registered through h5py's :func:`h5py.register_driver`) bounds it to
:data:`SWMR_READ_ATTEMPTS` attempts, about 17 ms of waiting per metadata block.

:func:`open_handle` opens a run file for the reader (:mod:`labjoint.storage.reader`)
through both: normally when finished, the SWMR way when a writer holds it.
"""

from __future__ import annotations

import ctypes
import glob
import os
from pathlib import Path

import h5py

from labjoint.errors import InputError

#: What h5py raises on a damaged or foreign file.
H5_FILE_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError)
#: Metadata read attempts of a SWMR reader (sleeps 2**k ns between them).
SWMR_READ_ATTEMPTS = 24
_DRIVER = "labjoint-swmr"


def _hdf5_library() -> ctypes.CDLL | None:
    """The HDF5 library h5py was linked with (the wheel's bundled copy), or None."""
    libs = glob.glob(os.path.join(os.path.dirname(h5py.__file__) + ".libs", "libhdf5-*.so*"))
    libs = [p for p in libs if "_hl" not in os.path.basename(p)]
    if len(libs) != 1:
        return None
    lib = ctypes.CDLL(libs[0])      # already loaded by h5py: the same library instance
    fn = getattr(lib, "H5Pset_metadata_read_attempts", None)
    if fn is None:
        return None
    fn.argtypes = [ctypes.c_int64, ctypes.c_uint]
    fn.restype = ctypes.c_int
    return lib


_LIB = _hdf5_library()


def _bounded_sec2(plist: h5py.h5p.PropFAID, **_: object) -> None:
    plist.set_fapl_sec2()
    if _LIB is not None and _LIB.H5Pset_metadata_read_attempts(plist.id, SWMR_READ_ATTEMPTS) < 0:
        raise OSError("H5Pset_metadata_read_attempts failed")


if _LIB is not None:
    h5py.register_driver(_DRIVER, _bounded_sec2)


def open_swmr_reader(path: str | Path) -> h5py.File:
    """``h5py.File(path, "r", swmr=True)`` with bounded metadata retries (see above)."""
    if _LIB is None:     # an h5py built against a system HDF5: its default retries
        return h5py.File(path, "r", swmr=True)
    return h5py.File(path, "r", swmr=True, driver=_DRIVER)


def run_identity(path: str | Path) -> tuple[str, str]:
    """(name, uid) of a run file, read without the rest of it (a catalog sync checks
    whether a file is a copy of a catalogued run before reading it whole)."""
    from labjoint.errors import InputError

    p = Path(path)
    try:
        try:
            f = h5py.File(p, "r")
        except OSError as exc:
            if "already open for write" not in str(exc):
                raise
            f = open_swmr_reader(p)
        with f:
            name, uid = f["entry/title"][()], f["entry/entry_identifier"][()]
    except H5_FILE_ERRORS as exc:
        raise InputError(f"not a readable run file: {exc}", file=str(p)) from None
    return tuple(v.decode().rstrip("\x00") if isinstance(v, bytes) else str(v)
                 for v in (name, uid))  # type: ignore[return-value]


class Handle:
    """The process's one open HDF5 file for a run path, with its datasets."""

    def __init__(self, f: h5py.File, swmr: bool) -> None:
        self.f, self.swmr, self.users = f, swmr, 0
        self.static: tuple | None = None
        self.entry = f["entry"]
        self.data = self.entry["data"]
        self.ds = {k: v for k, v in self.data.items() if isinstance(v, h5py.Dataset)}


def open_handle(p: Path) -> Handle:
    """A finished run file opened normally, one a writer holds (or held, and died) the SWMR
    way; anything that is not a labjoint run file, or is damaged, an InputError naming it."""
    swmr = False
    try:
        f = h5py.File(p, "r")
    except H5_FILE_ERRORS as exc:
        if "already open for write" not in str(exc):
            raise InputError(f"not a readable HDF5 file: {exc}", file=str(p)) from None
        try:  # a writer has it (or had it, and died): read it the SWMR way
            f = open_swmr_reader(p)
            swmr = True
        except H5_FILE_ERRORS as exc2:
            hint = ("; its writer died with it open: `labjoint recover` clears the flags"
                    if "not already open for SWMR writing" in str(exc2) else "")
            raise InputError(f"not a readable HDF5 file: {exc2}{hint}", file=str(p)) from None
    try:
        e = f.get("entry")
        if not isinstance(e, h5py.Group) or "labjoint_format" not in e.attrs or "data" not in e:
            raise InputError("not a labjoint run file (no /entry with @labjoint_format)",
                             file=str(p))
        return Handle(f, swmr)
    except InputError:
        f.close()
        raise
    except H5_FILE_ERRORS as exc:
        f.close()
        raise InputError(f"damaged run file: {exc}", file=str(p)) from None
