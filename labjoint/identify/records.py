"""Run files as channels with quantities and units, for `labjoint frf`, `modes` and
`distortion`: the drive (a force, N, or a voltage, V) and the responses
(displacement, velocity, acceleration), each named; bad input names file and channel."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

from labjoint.errors import InputError

RESPONSES = ("displacement", "velocity", "acceleration")
DRIVES = ("force", "voltage")


@dataclass
class Record:
    path: str
    name: str
    fs: float
    channels: dict[str, tuple[str, str, np.ndarray]]     # name -> (quantity, unit, samples)
    metadata: dict[str, Any] = field(default_factory=dict)

    def drive(self, name: str | None = None) -> str:
        """The drive channel: ``name``, else the one force, else the one voltage."""
        if name:
            if name not in self.channels:
                raise InputError(f"no channel {name!r}; channels: {list(self.channels)}",
                                 file=self.path, field="--drive")
            if self.channels[name][0] not in DRIVES:
                raise InputError(f"channel {name!r} measures {self.channels[name][0]}, not a force "
                                 "or a voltage", file=self.path, field=name)
            return name
        for q in DRIVES:
            cands = [n for n, c in self.channels.items() if c[0] == q]
            if len(cands) == 1:
                return cands[0]
            if len(cands) > 1:
                raise InputError(f"several {q} channels {cands}: name the drive with --drive",
                                 file=self.path, field="--drive")
        raise InputError("no drive channel (a force or a voltage) in the record",
                         file=self.path, field="drive")

    def responses(self, names: list[str] | None = None) -> list[str]:
        if names:
            for n in names:
                if n not in self.channels:
                    raise InputError(f"no channel {n!r}; channels: {list(self.channels)}",
                                     file=self.path, field="--responses")
                if self.channels[n][0] not in RESPONSES:
                    raise InputError(f"channel {n!r} measures {self.channels[n][0]}, not a response",
                                     file=self.path, field=n)
            return names
        out = [n for n, c in self.channels.items() if c[0] in RESPONSES]
        if not out:
            raise InputError("no response channel (displacement, velocity or acceleration)",
                             file=self.path, field="responses")
        return out


def load(path: str) -> Record:
    """A run file's (or import-format CSV's) channels in SI units with their quantities,
    through the storage layer's channel contract (:func:`labjoint.storage.reader.read_channels`)."""
    from labjoint.storage.reader import read_channels

    p = Path(path)
    if not p.exists():
        raise InputError("no such file", file=str(p))
    rec = read_channels(p)
    chans = {c.name: (c.quantity, c.units, np.asarray(c.samples, float)) for c in rec.channels.values()}
    return Record(str(p), rec.name, float(rec.sample_rate_hz), chans, dict(rec.metadata))


def level_of(rec: Any) -> float | None:
    """The record's stated excitation level (metadata ``level``), if any."""
    for key in ("level", "excitation_level", "level_v", "level_n"):
        v = rec.metadata.get(key)
        try:
            if v is not None and float(v) > 0:
                return float(v)
        except (TypeError, ValueError):
            continue
    return None


#: records with more samples than this (over all channels) are read in blocks
STREAM_VALUES = 1 << 24


@dataclass
class Streamed:
    """A run file's channels (quantities and SI units) with a block reader."""

    path: str
    name: str
    fs: float
    n: int
    channels: dict[str, tuple[str, str]]                 # name -> (quantity, unit)
    metadata: dict[str, Any]
    read: Callable[[list[str], int, int], np.ndarray]    # (names, start, stop) -> (len, m)

    def drive(self, name: str | None = None) -> str:
        return Record(self.path, self.name, self.fs, {k: (q, u, np.zeros(0)) for k, (q, u) in
                                                      self.channels.items()}).drive(name)

    def responses(self, names: list[str] | None = None) -> list[str]:
        return Record(self.path, self.name, self.fs, {k: (q, u, np.zeros(0)) for k, (q, u) in
                                                      self.channels.items()}).responses(names)


@contextlib.contextmanager
def streamed(path: str) -> Iterator[Streamed | None]:
    """A long run file opened for block reading, or None (a CSV, or a record small enough
    to load whole with :func:`load`)."""
    from labjoint.storage.channels import spec_quantity
    from labjoint.storage.reader import is_csv, open_run

    p = Path(path)
    if not p.exists():
        raise InputError("no such file", file=str(p))
    if is_csv(p):
        yield None
        return
    with open_run(p) as rf:
        specs = {s.name: s for s in rf.channels}
        if rf.n_samples * len(specs) <= STREAM_VALUES:
            yield None
            return
        qs = {n: spec_quantity(s) for n, s in specs.items()}

        def read(names: list[str], a: int, b: int) -> np.ndarray:
            out = np.empty((len(names), b - a))
            for i, nm in enumerate(names):
                rf.physical(nm, a, b, out=out[i])
                if qs[nm][1] != 1.0:
                    out[i] *= qs[nm][1]
            return out

        yield Streamed(str(p), rf.name, float(rf.sample_rate_hz), int(rf.n_samples),
                       {n: (q[0], q[2]) for n, q in qs.items()}, dict(rf.metadata), read)


def header(path: str) -> Record:
    """A run file's channels (quantities and SI units) without their samples: to check a
    request's drive and responses before any work (errors name the file and channel)."""
    from labjoint.storage.channels import spec_quantity
    from labjoint.storage.reader import is_csv, open_run

    p = Path(path)
    if not p.exists():
        raise InputError("no such file", file=str(p))
    if is_csv(p):
        return load(path)
    with open_run(p) as rf:
        chans = {s.name: (q[0], q[2], np.zeros(0)) for s in rf.channels for q in [spec_quantity(s)]}
        return Record(str(p), rf.name, float(rf.sample_rate_hz), chans, dict(rf.metadata))


def sample_count(path: str) -> int:
    """Samples per channel of a run file, from its header (a CSV is read)."""
    from labjoint.storage.reader import is_csv, open_run

    p = Path(path)
    if not p.exists():
        raise InputError("no such file", file=str(p))
    if is_csv(p):
        return min(c[2].size for c in load(path).channels.values())
    with open_run(p) as rf:
        return int(rf.n_samples)
