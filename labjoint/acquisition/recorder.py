"""The run side of a run engine: open a run, put blocks and markers into it, close it, and
hand every document to the callbacks (storage subscribes; acquisition never writes files).

A run's documents: RunStart, Blocks, Markers, RunStop; ``Block.first_sample`` and marker
samples count from the run's first sample.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from labjoint.acquisition.messages import RecordResult
from labjoint.documents import Block, Marker, RunStart, RunStop, utc_now
from labjoint.hardware.interfaces import ChannelSpec

log = logging.getLogger(__name__)


@dataclass
class _OpenRun:
    uid: str
    name: str
    start_abs: int
    n: int = 0


class Recorder:
    """Documents of the runs of one engine, to ``callbacks`` (``fn(name, doc)``); ``runs``:
    the results of the runs closed since :meth:`reset`."""

    def __init__(self, callbacks: Sequence[Callable[[str, Any], None]] = ()) -> None:
        self.callbacks = list(callbacks)
        self.open_run: _OpenRun | None = None
        self.runs: list[RecordResult] = []

    def reset(self) -> None:
        self.runs = []

    def emit(self, name: str, doc: Any) -> None:
        for cb in self.callbacks:
            cb(name, doc)

    def open(self, uid: str, name: str, channels: Sequence[ChannelSpec], fs: float,
             metadata: dict[str, Any], start_abs: int) -> None:
        """Start a run whose first sample is the DAQ's sample ``start_abs``."""
        self.open_run = _OpenRun(uid, name, start_abs)
        self.emit("start", RunStart(uid, name, list(channels), fs, metadata))

    def block(self, first_abs: int, volts: np.ndarray) -> None:
        """A block read at the DAQ's sample ``first_abs`` (dropped when no run is open)."""
        run = self.open_run
        if run is not None:
            self.emit("block", Block(run.uid, first_abs - run.start_abs, volts))
            run.n += volts.shape[1]

    def marker(self, name: str, sample_abs: int, data: dict[str, Any]) -> None:
        run = self.open_run
        if run is not None:
            self.emit("marker", Marker(run.uid, name, max(0, sample_abs - run.start_abs), data))

    def close(self, status: str, reason: str, metadata: dict[str, Any] | None = None) -> RecordResult:
        """End the open run (``metadata`` joins the stop document's); after a fault every
        callback gets the stop, whatever the others do."""
        run, self.open_run = self.open_run, None
        assert run is not None
        end = utc_now()
        doc = RunStop(run.uid, status, reason, end, run.n, {"end_time": end, **(metadata or {})})
        result = RecordResult(run.uid, run.name, status, run.n)
        self.runs.append(result)
        if status == "complete":
            self.emit("stop", doc)
        else:
            for cb in self.callbacks:
                try:
                    cb("stop", doc)
                except Exception as exc:
                    log.error("callback %r failed on the stop document: %s", cb, exc)
        return result
