"""Run files as channels with quantities and units, for `labjoint frf`, `modes` and
`distortion`: the drive (a force, N, or a voltage, V) and the responses
(displacement, velocity, acceleration), each named; bad input names file and channel."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

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


def level_of(rec: Record) -> float | None:
    """The record's stated excitation level (metadata ``level``), if any."""
    for key in ("level", "excitation_level", "level_v", "level_n"):
        v = rec.metadata.get(key)
        try:
            if v is not None and float(v) > 0:
                return float(v)
        except (TypeError, ValueError):
            continue
    return None
