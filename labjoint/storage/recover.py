"""Recover run files whose writer died (kill -9, power loss): mark them "incomplete".

A SWMR writer sets "open for write" flags in the HDF5 superblock; after a crash they
stay set and HDF5 refuses to open the file for writing ("file is already open for
write (may use <h5clear file> ...)"). h5py does not expose ``H5Fclear`` and the
``h5clear`` tool is not always installed, so :func:`clear_status_flags` does what
``h5clear -s`` does: it zeroes the consistency-flags byte of the version 2/3
superblock and rewrites the superblock's Jenkins lookup3 checksum (HDF5 file format
spec, "Superblock Format Version 2 and 3"). It first checks that its own checksum of
the unmodified superblock matches the stored one, so it never writes a superblock
layout it does not understand.
"""

from __future__ import annotations

import fcntl
import json
import logging
import os
import socket
from pathlib import Path

import h5py
import numpy as np

from labjoint.errors import InputError
from labjoint.storage import layout
from labjoint.storage.h5open import H5_FILE_ERRORS, open_swmr_reader
from labjoint.storage.writer import OPEN_FOR_WRITE, utc_now

log = logging.getLogger(__name__)
#: why a ``*.h5`` entry of a data directory is not read
NOT_A_FILE = "not a file (a directory, a broken link or a link loop)"

_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_M = 0xFFFFFFFF


def _rot(x: int, k: int) -> int:
    return ((x << k) | (x >> (32 - k))) & _M


def lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 ``hashlittle``: HDF5's metadata checksum.

    >>> hex(lookup3(b"Four score and seven years ago"))
    '0x17770551'
    """
    n = len(data)
    a = b = c = (0xDEADBEEF + n + initval) & _M
    o = 0
    while n > 12:
        a = (a + int.from_bytes(data[o:o + 4], "little")) & _M
        b = (b + int.from_bytes(data[o + 4:o + 8], "little")) & _M
        c = (c + int.from_bytes(data[o + 8:o + 12], "little")) & _M
        a = (a - c) & _M; a ^= _rot(c, 4); c = (c + b) & _M  # noqa: E702
        b = (b - a) & _M; b ^= _rot(a, 6); a = (a + c) & _M  # noqa: E702
        c = (c - b) & _M; c ^= _rot(b, 8); b = (b + a) & _M  # noqa: E702
        a = (a - c) & _M; a ^= _rot(c, 16); c = (c + b) & _M  # noqa: E702
        b = (b - a) & _M; b ^= _rot(a, 19); a = (a + c) & _M  # noqa: E702
        c = (c - b) & _M; c ^= _rot(b, 4); b = (b + a) & _M  # noqa: E702
        n -= 12
        o += 12
    if n == 0:
        return c
    tail = data[o:o + n] + bytes(12 - n)
    a = (a + int.from_bytes(tail[0:4], "little")) & _M
    b = (b + int.from_bytes(tail[4:8], "little")) & _M
    c = (c + int.from_bytes(tail[8:12], "little")) & _M
    c ^= b; c = (c - _rot(b, 14)) & _M  # noqa: E702
    a ^= c; a = (a - _rot(c, 11)) & _M  # noqa: E702
    b ^= a; b = (b - _rot(a, 25)) & _M  # noqa: E702
    c ^= b; c = (c - _rot(b, 16)) & _M  # noqa: E702
    a ^= c; a = (a - _rot(c, 4)) & _M  # noqa: E702
    b ^= a; b = (b - _rot(a, 14)) & _M  # noqa: E702
    c ^= b; c = (c - _rot(b, 24)) & _M  # noqa: E702
    return c


@layout.locked
def clear_status_flags(path: str | Path) -> bool:
    """Clear the superblock's file-consistency flags (``h5clear -s``). True if any were set."""
    p = Path(path)
    with open(p, "r+b") as fh:
        head = fh.read(12)
        if len(head) < 12 or head[:8] != _SIGNATURE:
            raise InputError("not an HDF5 file (no superblock at offset 0)", file=str(p))
        version, size_off = head[8], head[9]
        if version not in (2, 3):
            return False  # version 0/1 superblocks carry no SWMR flags
        length = 12 + 4 * size_off
        fh.seek(0)
        block = fh.read(length + 4)
        stored = int.from_bytes(block[length:length + 4], "little")
        if lookup3(block[:length]) != stored:
            raise InputError("superblock checksum does not verify; not clearing flags", file=str(p))
        if block[11] == 0:
            return False
        new = block[:11] + b"\x00" + block[12:length]
        fh.seek(0)
        fh.write(new + lookup3(new).to_bytes(4, "little"))
        fh.flush()
        os.fsync(fh.fileno())
    return True


#: superblock consistency flags (HDF5 file format spec, superblock version 2/3)
_WRITE_ACCESS, _SWMR_WRITE = 0x01, 0x04


def _consistency_flags(p: Path) -> int:
    """The superblock's file-consistency flags byte (0 for version 0/1 superblocks)."""
    try:
        with open(p, "rb") as fh:
            head = fh.read(12)
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc.strerror or exc}", file=str(p)) from None
    if len(head) < 12 or head[:8] != _SIGNATURE:
        raise InputError("not an HDF5 file (no superblock at offset 0)", file=str(p))
    return head[11] if head[8] in (2, 3) else 0


@layout.locked
def clear_dead_writer(path: str | Path) -> bool:
    """Clear the open-for-write flags a dead non-SWMR writer left (a ``labjoint
    reprocess`` killed while it wrote ``/entry/processed``); True if it cleared them.

    A non-SWMR HDF5 writer holds an exclusive ``flock`` on the file while it lives, and
    the kernel drops it when the process dies: the flags are cleared only if that lock
    can be taken now (and it is held while clearing). Flags of a SWMR writer (the
    acquisition's, which holds no lock) are left to :func:`recover`, which judges the
    writer by the pid recorded in the file. Files this process writes are left alone.
    """
    p = Path(path)
    if str(p.resolve()) in OPEN_FOR_WRITE:
        return False
    flags = _consistency_flags(p)
    if not flags & _WRITE_ACCESS or flags & _SWMR_WRITE:
        return False
    with open(p, "rb") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            return False                   # a live process has it open for writing
        try:
            return clear_status_flags(p)
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _writer_alive(pid: int, host: str) -> bool:
    if pid <= 0 or pid == os.getpid():
        return False
    if host != socket.gethostname():
        return True  # cannot tell: assume it is
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@layout.locked
def _read_state(p: Path) -> tuple[str, int, str]:
    try:
        try:
            f = h5py.File(p, "r")          # a damaged file fails at once
        except OSError as exc:
            if "already open for write" not in str(exc):
                raise
            f = open_swmr_reader(p)        # a writer has (or had) it open
        with f:
            status = f["entry/status"][()]
            acq = f["entry/acquisition"]
            host = acq["writer_host"][()]
            return (status.decode().strip("\x00 "), int(acq["writer_pid"][()]),
                    host.decode() if isinstance(host, bytes) else str(host))
    except H5_FILE_ERRORS as exc:
        raise InputError(f"cannot read run file: {exc}", file=str(p)) from None


@layout.locked
def recover(path: str | Path, *, force: bool = False, catalog=None) -> bool:
    """Mark a run file whose writer is gone "incomplete"; True if it was changed.

    Files with a final status are left alone. Refuses (InputError) while the writer
    recorded in the file is still alive on this host, or this process writes it,
    unless ``force``. Channels are cut to the length all of them reached.
    """
    p = Path(path)
    if not p.exists():
        raise InputError("no such run file", file=str(p))
    if str(p.resolve()) in OPEN_FOR_WRITE:
        raise InputError("this process is writing the run file", file=str(p))
    status, pid, host = _read_state(p)
    if status != "running":
        return False
    if not force and _writer_alive(pid, host):
        raise InputError(f"writer process {pid} is still running", file=str(p))
    clear_status_flags(p)
    try:
        _close_channels(p)
    except H5_FILE_ERRORS as exc:
        raise InputError(f"cannot recover run file: {exc}", file=str(p)) from None
    if catalog is not None:
        catalog.add(p)
    return True


def _close_channels(p: Path) -> int:
    """Cut the channels to their common length and mark the run "incomplete"."""
    with h5py.File(p, "r+") as f:
        e = f["entry"]
        data = e["data"]
        names = [n for n in data if isinstance(data[n], h5py.Dataset)]
        n = min(data[k].shape[0] for k in names)
        for k in names:
            if data[k].shape[0] != n:
                data[k].resize((n,))
        note = {"reason": "writer stopped without RunStop; recovered", "status": "incomplete",
                "recovered_at": utc_now(), "n_samples": n}
        layout.append_rows(e["acquisition/events"],
                           layout.event_rows("stop", "incomplete", n, json.dumps(note)))
        e["n_samples"][()] = n
        e["status"][()] = np.bytes_(b"incomplete")
    return n


def recover_all(data_dir: str | Path, *, catalog=None, cleared: list[Path] | None = None,
                unreadable: dict[str, str] | None = None) -> list[Path]:
    """At start-up: recover every "running" run in ``data_dir`` whose writer is gone,
    clear the open-for-write flags dead non-SWMR writers left on finished runs
    (:func:`clear_dead_writer`; appended to ``cleared``), and delete temporary files
    left by dead writers or imports. Files that cannot be read are skipped and put in
    ``unreadable`` (file -> why) if given, else logged as warnings. Returns the files
    marked "incomplete"."""
    d = Path(data_dir)
    done: list[Path] = []
    level = logging.WARNING if unreadable is None else logging.INFO   # else the caller says it
    if not d.is_dir():
        return done
    for tmp in sorted(d.glob(".*.h5.tmp-*")):
        pid = tmp.name.rsplit(".tmp-", 1)[-1].split("-", 1)[0]
        if pid.isdigit() and not _writer_alive(int(pid), socket.gethostname()) \
                and int(pid) != os.getpid():
            tmp.unlink(missing_ok=True)
    for p in sorted(d.glob("*.h5")):
        if not p.is_file():          # before resolve(): a symlink loop raises there
            log.log(level, "recover: skipping %s: %s", p, NOT_A_FILE)
            if unreadable is not None:
                unreadable[str(p)] = NOT_A_FILE
            continue
        if str(p.resolve()) in OPEN_FOR_WRITE:
            continue
        try:
            if clear_dead_writer(p):
                log.warning("cleared the open-for-write flags a dead writer left on %s", p)
                if cleared is not None:
                    cleared.append(p)
            if recover(p, catalog=catalog):
                done.append(p)
        except InputError as exc:
            log.log(level, "recover: skipping %s", exc)   # InputError names the file
            if unreadable is not None:
                unreadable[str(p)] = exc.message
    return done
