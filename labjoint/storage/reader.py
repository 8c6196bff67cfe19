"""Read run files: raw volts, physical units (calibration applied), chunked iteration.

A file a writer holds open (or held when it died) is opened in SWMR-read mode, so a
run still being written can be read;
:meth:`RunFile.refresh` picks up what the writer has flushed since.

Thread safety: a process holds one HDF5 handle per run file, shared by every
:class:`RunFile` opened on it and reference-counted (``Handle``), and every HDF5 call
goes through :data:`labjoint.storage.layout.H5_LOCK`. Two handles on one file in one
process share HDF5's file state, and refreshing one while the other reads made
concurrent readers get another window's samples (chunk 10 read as chunk 0).
Imported (CSV) runs store physical values with unity calibration, so ``volts`` and
``physical`` return the same numbers for them.
"""

from __future__ import annotations

import copy
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import h5py
import numpy as np

from labjoint.errors import InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage import layout
from labjoint.storage.channels import ChannelRecord, make_record, spec_quantity
from labjoint.storage.csv_parse import parse_csv
from labjoint.storage.h5open import H5_FILE_ERRORS, Handle, open_handle
from labjoint.storage.roles import channel_roles
from labjoint.storage.run import Run


def _s(v: Any) -> str:
    if isinstance(v, bytes):
        return v.decode().rstrip("\x00")
    if isinstance(v, np.ndarray) and v.shape == ():
        return _s(v[()])
    return str(v)


@dataclass
class DataBlock:
    """Samples ``start:stop`` of a run: time (s) and one array per channel."""

    start: int
    stop: int
    time: np.ndarray
    data: dict[str, np.ndarray]


#: Samples per channel :meth:`RunFile.to_run` reads whole (2000 s at 50 kS/s; 800 MB a
#: channel): a file declaring 1e9 was read until memory ran out.
MAX_WHOLE_RUN_SAMPLES = 100_000_000

#: Open handles by resolved path (guarded by H5_LOCK).
_HANDLES: dict[str, Handle] = {}
#: The static part of recently read files by (path, inode, device): a run's channels,
#: start metadata, title, identifier and source are written when it starts and never
#: change, and parsing them is most of the cost of opening a file.
_STATIC: dict[tuple[str, int, int], tuple] = {}
_STATIC_MAX = 512


def _static_part(rf: "RunFile") -> tuple:
    st = os.stat(rf.path)
    key = (str(rf.path.resolve()), st.st_ino, st.st_dev)
    hit = _STATIC.get(key)
    if hit is None:
        chans = tuple(rf._read_channels())
        md = json.loads(_s(rf._e["metadata_json"][()]))
        if "channel_quantities" not in md:       # written before channels carried quantities
            md.update(layout.channel_metadata(md, list(chans),
                                              {c.name: spec_quantity(c)[0] for c in chans}))
        hit = (chans, md,
               _s(rf._e["title"][()]), _s(rf._e["entry_identifier"][()]),
               _s(rf._e.attrs.get("labjoint_source", "")))
        if len(_STATIC) >= _STATIC_MAX:
            _STATIC.pop(next(iter(_STATIC)))
        _STATIC[key] = hit
    return hit


class RunFile:
    """An open run file (use :func:`open_run`). Close it, or use it as a context manager."""

    @layout.locked
    def __init__(self, path: Path, handle: Handle) -> None:
        self.path = path
        self._h = handle
        self._f = handle.f
        self._closed = False
        try:
            self._e = handle.entry
            self._data = handle.data
            self._ds = handle.ds
            if handle.static is None:     # written once at the run's start, never changed
                handle.static = _static_part(self)
            chans, static, self.name, self.uid, self.source = handle.static
            self.channels: list[ChannelSpec] = list(chans)
            self._static = copy.deepcopy(static)
            self.refresh()
        except H5_FILE_ERRORS as exc:
            self.close()
            raise InputError(f"damaged run file: {exc}", file=str(path)) from None

    def _read_channels(self) -> list[ChannelSpec]:
        inst = self._e["instrument"]
        names = [_s(n) for n in self._data.attrs["labjoint_channels"]]
        return [layout.read_sensor(inst[n]) for n in names]

    # -- state that changes while a run is written ------------------------------
    @layout.locked
    def refresh(self) -> None:
        """Re-read what a live writer has flushed (sample count, status, events)."""
        if self._h.swmr:                  # another process writes it: pick up its flushes
            for key in ("status", "end_time", "n_samples", "acquisition/gaps",
                        "acquisition/events", "acquisition/continuous"):
                self._e[key].refresh()
            for ds in self._ds.values():
                ds.refresh()
        self.status = _s(self._e["status"][()]).strip()
        self.end_time = _s(self._e["end_time"][()])
        self.n_samples = min(ds.shape[0] for ds in self._ds.values())
        self.gaps = [(int(a), int(b)) for a, b in self._e["acquisition/gaps"][()]]
        self.events = layout.parse_events(self._e["acquisition/events"][()])
        self.metadata = self._metadata()

    def _metadata(self) -> dict[str, Any]:
        md = dict(self._static)
        stops = [ev for ev in self.events if ev["kind"] == "stop"]
        if stops and isinstance(stops[-1]["data"], dict):
            last = stops[-1]["data"]
            md.update(last.get("metadata") or {})
            md["reason"] = last.get("reason", "")
        md.update(name=self.name, uid=self.uid, status=self.status, end_time=self.end_time,
                  n_samples=self.n_samples, source=self.source,
                  gaps=[list(g) for g in self.gaps],
                  continuous=bool(self._e["acquisition/continuous"][()]),
                  markers=[{k: ev[k] for k in ("name", "sample", "data")}
                           for ev in self.events if ev["kind"] == "marker"])
        return md

    # -- simple properties -------------------------------------------------------
    @property
    def sample_rate_hz(self) -> float:
        return float(self.metadata["sample_rate_hz"])

    @property
    def frequency_hz(self) -> float | None:
        f = self.metadata.get("frequency_hz")
        return None if f is None else float(f)

    @property
    def channel_names(self) -> list[str]:
        return [c.name for c in self.channels]

    @property
    @layout.locked
    def processed_names(self) -> list[str]:
        """Names of the processed-result groups in the file."""
        g = self._e.get("processed")
        return [] if g is None else [k for k in g if not k.startswith(".")]

    def channel(self, name: str) -> ChannelSpec:
        """The :class:`ChannelSpec` of channel ``name``."""
        for c in self.channels:
            if c.name == name:
                return c
        raise InputError(f"no channel {name!r}; channels: {self.channel_names}",
                         file=str(self.path), field=name)

    # -- data --------------------------------------------------------------------
    def _slice(self, start: int, stop: int | None) -> slice:
        a, b, _ = slice(start, stop).indices(self.n_samples)
        return slice(a, max(a, b))

    @layout.locked
    def time(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Time axis (s) of samples ``start:stop``."""
        return self._ds["time"][self._slice(start, stop)]

    @layout.locked
    def volts(self, channel: str, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Raw stored values of ``channel`` (volts for acquired runs)."""
        self.channel(channel)
        return self._ds[channel][self._slice(start, stop)]

    def physical(self, channel: str, start: int = 0, stop: int | None = None, *,
                 out: np.ndarray | None = None) -> np.ndarray:
        """``channel`` in its physical unit: volts times the calibration at the run's
        frequency (written into ``out`` if given, e.g. a row of a block being filled: the
        samples are then read straight into it, without a temporary array)."""
        spec = self.channel(channel)
        scale = spec.units_per_volt(self.frequency_hz)
        if out is not None and self._read_into(channel, start, stop, out):
            return np.multiply(out, scale, out=out)
        return np.multiply(self.volts(channel, start, stop), scale, out=out)

    @layout.locked
    def _read_into(self, channel: str, start: int, stop: int | None, out: np.ndarray) -> bool:
        """Read samples ``start:stop`` of a float64 channel into ``out`` (same length,
        contiguous float64); False (nothing read) when that does not apply."""
        ds = self._ds[channel]
        sel = self._slice(start, stop)
        if ds.dtype != np.float64 or out.dtype != np.float64 or out.ndim != 1 \
                or not out.flags.c_contiguous or out.size != sel.stop - sel.start:
            return False
        if out.size:
            ds.read_direct(out, source_sel=np.s_[sel.start:sel.stop])
        return True

    def iter_blocks(self, block_samples: int, channels: list[str] | None = None,
                    overlap: int = 0, physical: bool = True) -> Iterator[DataBlock]:
        """Consecutive blocks of ``block_samples`` (the last may be shorter), each starting
        ``overlap`` samples before the previous one ended; reads one block at a time."""
        if block_samples < 1:
            raise InputError("block_samples must be >= 1", field="block_samples")
        if not 0 <= overlap < block_samples:
            raise InputError("overlap must be in [0, block_samples)", field="overlap")
        names = self.channel_names if channels is None else list(channels)
        for n in names:
            self.channel(n)
        read = self.physical if physical else self.volts
        n_total, step, start = self.n_samples, block_samples - overlap, 0
        while start < n_total:
            stop = min(start + block_samples, n_total)
            yield DataBlock(start, stop, self.time(start, stop),
                            {n: read(n, start, stop) for n in names})
            if stop == n_total:
                break
            start += step

    @layout.locked
    def processed(self, group_name: str) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Arrays and attributes of ``/entry/processed/<group_name>``."""
        g = self._e.get(f"processed/{group_name}")
        if g is None or group_name.startswith("."):
            raise InputError(f"no processed group {group_name!r}; have {self.processed_names}",
                             file=str(self.path), field=group_name)
        return _read_group(g), {k: _attr(v) for k, v in g.attrs.items() if k != "NX_class"}

    @layout.locked
    def to_run(self, force: str = "joint") -> Run:
        """The run in SI units: relative displacement and the joint (or reference) force."""
        md = self.metadata
        disp, fch = channel_roles(md, self.channel_names).require(force, str(self.path))
        if self.n_samples > MAX_WHOLE_RUN_SAMPLES:     # checked as declared, before reading
            raise InputError(f"declares {self.n_samples:.3g} samples per channel; a whole run "
                             f"is read into memory up to {MAX_WHOLE_RUN_SAMPLES:.3g} (the "
                             "streaming pipelines, labjoint analyze, read any length)",
                             file=str(self.path), field="n_samples")
        chans = {c: self.physical(c) for c in self.channel_names}
        displacement = chans[disp[0]] - chans[disp[1]] if len(disp) == 2 else chans[disp[0]].copy()
        return Run(name=self.name, time=self.time(), displacement=displacement,
                   force=chans[fch].copy(), metadata=dict(md), channels=chans,
                   path=str(self.path))

    @layout.locked
    def to_channels(self, channels: list[str] | None = None) -> ChannelRecord:
        """Every channel (or those named) in SI units with quantity, units and role."""
        names = self.channel_names if channels is None else list(channels)
        specs = [self.channel(n) for n in names]
        md = self.metadata
        roles = channel_roles(md, self.channel_names)
        return make_record(self.name, self.time(), self.sample_rate_hz, md, specs,
                           {n: self.physical(n) for n in names}, roles, str(self.path))

    @layout.locked
    def close(self) -> None:
        """Release this reader; the file closes when its last reader in the process does."""
        if self._closed:
            return
        self._closed = True
        self._h.users -= 1
        if self._h.users <= 0:
            key = next((k for k, h in _HANDLES.items() if h is self._h), None)
            if key is not None:
                del _HANDLES[key]
            self._h.f.close()

    def __enter__(self) -> "RunFile":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _attr(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


def _read_group(g: h5py.Group) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in g.items():
        if isinstance(v, h5py.Group):
            out[k] = _read_group(v)
        else:
            val = v[()]
            out[k] = _s(val) if isinstance(val, bytes) else val
    return out


@layout.locked
def open_run(path: str | Path) -> RunFile:
    """Open a run file for reading (works while it is being written).

    Finished files are opened normally, so a truncated or damaged file fails at once
    (SWMR readers retry checksum failures, expecting a writer to catch up).
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("no such run file", file=str(p))
    key = str(p.resolve())
    handle = _HANDLES.get(key)
    if handle is not None and not handle.f.id.valid:      # closed behind our back
        del _HANDLES[key]
        handle = None
    if handle is None:
        handle = open_handle(p)
        _HANDLES[key] = handle
    handle.users += 1
    return RunFile(p, handle)


def read_run(path: str | Path, force: str = "joint") -> Run:
    """Load a whole run in SI units; ``force`` is "joint" (interface sensor) or "reference".

    Displacement is ``disp_1 - disp_2`` (metadata ``displacement_channels``), or the
    single ``displacement`` channel of an imported run.
    """
    with open_run(path) as rf:
        return rf.to_run(force=force)


#: File suffixes read as CSV records in the import format (design.md); anything else is a run file.
CSV_SUFFIXES = (".csv", ".txt")


def is_csv(path: str | Path) -> bool:
    """Whether ``path`` is read as a CSV record (by its suffix)."""
    return Path(path).suffix.lower() in CSV_SUFFIXES


def read_channels(path: str | Path, channels: list[str] | None = None) -> ChannelRecord:
    """A run file (or a CSV record in the import format) as a :class:`ChannelRecord`:
    time, sample rate, metadata and per channel samples (SI), quantity, units, role
    (``drive``, ``response``, ``other``; tests/test_channel_contract.py shows each)."""
    p = Path(path)
    if is_csv(p):
        return parse_csv(p).to_channels(channels)
    with open_run(p) as rf:
        return rf.to_channels(channels)


def read_any(path: str | Path, force: str = "joint") -> Run:
    """A whole run from a run file or a CSV record (by suffix), with the same channel
    names either way: an imported run file's (``displacement``, ``force`` and the extra
    columns), so a CSV and the run file ``labjoint import`` makes of it read alike."""
    p = Path(path)
    if is_csv(p):
        if force != "joint":
            raise InputError("a CSV record has one force column; force='reference' applies "
                             "to run files only", file=str(p), field="force")
        return parse_csv(p).to_run()
    return read_run(p, force=force)
