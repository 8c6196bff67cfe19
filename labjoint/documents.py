"""Documents a run emits, bluesky-style: ``("start", RunStart)``, ``("block", Block)``...,
``("stop", RunStop)``. Storage subscribes with a callable ``callback(name, doc)``, so
acquisition code never touches HDF5. The documents sit below both (acquisition emits
them, storage and the daemon's live view consume them), so neither imports the other.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any, Callable, Protocol

import numpy as np

from labjoint.hardware.interfaces import ChannelSpec

RUN_STATUSES = ("running", "complete", "failed", "aborted", "limit", "incomplete")



def utc_now() -> str:
    """The current UTC time, ISO 8601 (every timestamp a run, a job or the daemon stores)."""
    return datetime.now(timezone.utc).isoformat()

@dataclass
class RunStart:
    """Opens a run. ``metadata`` keys (SI, see design.md): frequency_hz, excitation_vpp,
    offset_v, torque_nm, normal_force_n, sample_rate_hz, plan, plan_step, generator
    (dict of read-back settings), start_time (ISO 8601), software_version, plus any
    other JSON-serialisable key."""

    uid: str
    name: str
    channels: list[ChannelSpec]
    sample_rate_hz: float
    metadata: dict[str, Any] = field(default_factory=dict)


@dataclass
class Block:
    """A contiguous block of raw samples: volts, shape (n_channels, n).

    ``first_sample`` is the DAQ's sample counter of column 0, so gaps are detectable.
    """

    uid: str
    first_sample: int
    volts: np.ndarray


@dataclass
class Marker:
    """A named point in the run (e.g. ``steady`` reached at a sample index)."""

    uid: str
    name: str
    sample: int
    data: dict[str, Any] = field(default_factory=dict)


@dataclass
class RunStop:
    """Closes a run with its final status and the reason if it did not complete."""

    uid: str
    status: str
    reason: str = ""
    end_time: str = ""
    n_samples: int = 0
    metadata: dict[str, Any] = field(default_factory=dict)


Document = RunStart | Block | Marker | RunStop


class Callback(Protocol):
    def __call__(self, name: str, doc: Document) -> None: ...


def fan_out(*callbacks: Callable[[str, Document], None]) -> Callable[[str, Document], None]:
    """One callback that forwards every document to each of ``callbacks``."""

    def _cb(name: str, doc: Document) -> None:
        for cb in callbacks:
            cb(name, doc)

    return _cb
