"""Every channel of a record with its quantity, SI unit and role: :class:`ChannelRecord`.

The one view of a measurement the layers above storage use when they need more than the
joint's displacement and force (FRFs, modes, distortion, models driven by a voltage):
per channel the samples in SI units, the quantity (displacement, velocity, acceleration,
force, voltage, or another kept as given), its unit (:mod:`labjoint.storage.quantities`)
and its role (``drive``, ``response`` or ``other``). Read one with
:func:`labjoint.storage.reader.read_channels`.

Quantities of files written before channels carried them come from their stored channel
specs (``measurement`` and ``unit`` of each NXsensor), never from a channel's name; a
spec whose unit does not fit its quantity (old CSV imports guessed from name suffixes)
is reported as quantity ``unknown`` with its unit as stored, not converted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage.quantities import DRIVE_QUANTITIES, SI_UNITS, to_si

UNKNOWN = "unknown"


def spec_quantity(spec: ChannelSpec) -> tuple[str, float, str]:
    """(quantity, factor from the spec's physical unit to SI, SI unit) of a channel spec."""
    try:
        factor, units = to_si(spec.quantity, spec.unit, channel=spec.name)
    except InputError:
        return UNKNOWN, 1.0, spec.unit
    return spec.quantity, factor, units


@dataclass
class Channel:
    """One channel: samples in ``units`` (SI for known quantities), its quantity and role."""

    name: str
    samples: np.ndarray
    quantity: str
    units: str
    role: str = "other"
    sensor: str = ""


@dataclass
class ChannelRecord:
    """A record: time base (s), sample rate, metadata and every channel (SI units)."""

    name: str
    time: np.ndarray
    sample_rate_hz: float
    channels: dict[str, Channel]
    metadata: dict[str, Any] = field(default_factory=dict)
    path: str | None = None

    @property
    def drives(self) -> list[Channel]:
        """The drive channels (a force, a voltage), in file order."""
        return [c for c in self.channels.values() if c.role == "drive"]

    @property
    def responses(self) -> list[Channel]:
        """The response channels, in file order."""
        return [c for c in self.channels.values() if c.role == "response"]

    def channel(self, name: str) -> Channel:
        """The channel called ``name`` (InputError naming the file otherwise)."""
        try:
            return self.channels[name]
        except KeyError:
            raise InputError(f"no channel {name!r}; channels: {list(self.channels)}",
                             file=self.path, field=name) from None

    def drive(self, quantity: str | None = None) -> Channel:
        """The (first) drive channel, of ``quantity`` ("force" or "voltage") if given.

        Refused with one line naming the file when the record has none: in particular a
        force is asked for and the only drive is a voltage (never used as a force).
        """
        if quantity is not None and quantity not in DRIVE_QUANTITIES:
            raise InputError(f"a drive is one of {DRIVE_QUANTITIES}, not {quantity!r}",
                             field="quantity")
        drives = self.drives
        hit = [c for c in drives if quantity is None or c.quantity == quantity]
        if hit:
            return hit[0]
        if not drives:
            raise InputError("no drive channel: the record lists none (drive_channels); "
                             f"channels: {list(self.channels)}", file=self.path,
                             field="drive_channels")
        if all(c.quantity == "voltage" for c in drives):
            what = f"the drive is a voltage ({', '.join(c.name for c in drives)})"
        else:
            what = "the drives are " + ", ".join(f"{c.name} ({c.quantity})" for c in drives)
        raise InputError(f"no {quantity} channel: {what}; a voltage is never "
                         "used as a force", file=self.path, field=drives[0].name)


def make_record(name: str, time: np.ndarray, sample_rate_hz: float, metadata: dict[str, Any],
                specs: list[ChannelSpec], physical: dict[str, np.ndarray], roles: Any,
                path: str | None) -> ChannelRecord:
    """A :class:`ChannelRecord` from channel specs and their physical-unit samples."""
    chans = {}
    for spec in specs:
        quantity, factor, units = spec_quantity(spec)
        x = physical[spec.name]
        chans[spec.name] = Channel(spec.name, x * factor if factor != 1.0 else x, quantity,
                                   units, roles.role(spec.name), spec.sensor)
    return ChannelRecord(name, time, float(sample_rate_hz), chans, dict(metadata), path)


__all__ = ["Channel", "ChannelRecord", "SI_UNITS", "UNKNOWN", "make_record", "spec_quantity"]
