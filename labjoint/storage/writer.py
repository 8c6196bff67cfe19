"""Streams run documents into one NeXus-style HDF5 file per run (SWMR, crash-safe).

``RunWriter`` is a document callback (``writer(name, doc)``, see
:mod:`labjoint.documents`). The file is created under a hidden temporary
name, laid out completely, switched to SWMR mode and only then linked to
``<data_dir>/<run name>.h5``, so a half-created file never exists under a run's name.
From then on the writer only appends to or overwrites pre-created datasets (the SWMR
rules), flushes on a clock (``flush_interval_s``), and writes the final ``status``
last. Other processes can read the file at any time (``open_run``); after a kill -9
it still opens and holds every flushed sample, with ``status`` still "running"
until :func:`labjoint.storage.recover.recover` marks it "incomplete".
"""

from __future__ import annotations

import logging
import os
import secrets
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import h5py
import numpy as np

from labjoint.documents import RUN_STATUSES, Block, Marker, RunStart, RunStop, utc_now
from labjoint.errors import InputError
from labjoint.storage import layout

log = logging.getLogger(__name__)

#: Absolute paths of run files this process is writing (recover() refuses them).
OPEN_FOR_WRITE: set[str] = set()


@dataclass
class _OpenRun:
    path: Path
    file: h5py.File
    sample_rate_hz: float
    channels: list[h5py.Dataset]
    time: h5py.Dataset
    n_written: int = 0
    next_expected: int = 0
    last_flush: float = 0.0
    gaps: list[tuple[int, int]] = field(default_factory=list)

    def ds(self, key: str) -> h5py.Dataset:
        return self.file[key]


class RunWriter:
    """Document callback writing each run to ``<data_dir>/<run name>.h5``.

    ``catalog`` (a :class:`labjoint.storage.catalog.Catalog`) is updated when a run
    starts and when it stops. Data are flushed when ``flush_interval_s`` has passed on
    ``clock`` since the last flush, checked on every document and by
    :meth:`flush_if_due` (call it periodically if blocks may stop arriving). Not
    thread-safe: call it from one thread, like the documents it consumes.
    """

    def __init__(self, data_dir: str | Path, catalog: Any = None, flush_interval_s: float = 1.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.data_dir = data_dir
        self.catalog = catalog
        self.flush_interval_s = flush_interval_s
        self.clock = clock
        self._runs: dict[str, _OpenRun] = {}
        #: run files whose catalog update failed (a catalog outage), with why: the files
        #: are complete; :meth:`retry_catalog` (or ``labjoint recover``) indexes them
        self.catalog_pending: dict[Path, str] = {}

    # -- document dispatch -------------------------------------------------------
    @layout.locked
    def __call__(self, name: str, doc: Any) -> None:
        if name == "start" and isinstance(doc, RunStart):
            self.start(doc)
        elif name == "block" and isinstance(doc, Block):
            self.block(doc)
        elif name == "marker" and isinstance(doc, Marker):
            self.marker(doc)
        elif name == "stop" and isinstance(doc, RunStop):
            self.stop(doc)
        else:
            raise InputError(f"unexpected document {name!r} of type {type(doc).__name__}",
                             field="document")

    @property
    def open_paths(self) -> list[Path]:
        """Files of the runs being written."""
        return [r.path for r in self._runs.values()]

    def _run(self, uid: str) -> _OpenRun:
        try:
            return self._runs[uid]
        except KeyError:
            raise InputError(f"no open run with uid {uid!r} (RunStart missing?)", field="uid") from None

    # -- start -------------------------------------------------------------------
    @layout.locked
    def start(self, doc: RunStart) -> Path:
        """Create the run file (temp name, full layout, SWMR on, then link to its name)."""
        if doc.uid in self._runs:
            raise InputError(f"run uid {doc.uid!r} is already open", field="uid")
        data_dir = Path(self.data_dir)
        data_dir.mkdir(parents=True, exist_ok=True)
        final = layout.run_path(data_dir, doc.name)
        if final.exists():
            raise InputError("a run file with this name already exists", file=str(final))
        md = dict(doc.metadata)
        md.setdefault("start_time", utc_now())
        md.setdefault("plan", "")
        tmp = layout.temp_path(final, f"{os.getpid()}-{secrets.token_hex(4)}")
        f = h5py.File(tmp, "w", libver="latest")
        try:
            layout.create_layout(
                f, name=doc.name, uid=doc.uid, channels=list(doc.channels),
                sample_rate_hz=float(doc.sample_rate_hz), metadata=md, source="acquired",
                signal=str(md.get("joint_force_channel") or md.get("reference_force_channel") or "shear_nc"),
                data_units="V",
                writer_pid=os.getpid(), writer_host=socket.gethostname())
            f.swmr_mode = True
            layout.publish(tmp, final)
        except BaseException:
            f.close()
            tmp.unlink(missing_ok=True)
            raise
        data = f["entry/data"]
        run = _OpenRun(path=final, file=f, sample_rate_hz=float(doc.sample_rate_hz),
                       channels=[data[c.name] for c in doc.channels], time=data["time"],
                       last_flush=self.clock())
        self._runs[doc.uid] = run
        OPEN_FOR_WRITE.add(str(final.resolve()))
        self._catalog_add(final)
        return final

    # -- blocks ------------------------------------------------------------------
    @layout.locked
    def block(self, doc: Block) -> None:
        """Append a block; a sample-counter jump is recorded as a gap (expected, got)."""
        run = self._run(doc.uid)
        volts = np.asarray(doc.volts, dtype=np.float64)
        if volts.ndim != 2 or volts.shape[0] != len(run.channels):
            raise InputError(f"block volts must have shape ({len(run.channels)}, n), "
                             f"got {volts.shape}", file=str(run.path), field="volts")
        first = int(doc.first_sample)
        if first != run.next_expected:
            self._gap(run, run.next_expected, first)
            if first < run.next_expected:  # counter went back: drop what is already stored
                skip = run.next_expected - first
                volts, first = volts[:, skip:], run.next_expected
        n = volts.shape[1]
        if n:
            a, b = run.n_written, run.n_written + n
            for ds, row in zip(run.channels, volts):
                ds.resize((b,))
                ds[a:b] = row
            run.time.resize((b,))
            run.time[a:b] = (first + np.arange(n, dtype=np.float64)) / run.sample_rate_hz
            run.n_written = b
            run.next_expected = first + n
        self._flush_if_due(run)

    def _gap(self, run: _OpenRun, expected: int, got: int) -> None:
        log.warning("%s: sample counter expected %d, got %d", run.path.name, expected, got)
        run.gaps.append((expected, got))
        layout.append_rows(run.ds("entry/acquisition/gaps"), np.array([[expected, got]], dtype="<i8"))
        run.ds("entry/acquisition/continuous")[()] = False

    # -- markers -----------------------------------------------------------------
    @layout.locked
    def marker(self, doc: Marker) -> None:
        """Store a named sample marker with its JSON data."""
        run = self._run(doc.uid)
        rows = layout.event_rows("marker", doc.name, int(doc.sample),
                                 layout.to_json(doc.data, field="marker.data"))
        layout.append_rows(run.ds("entry/acquisition/events"), rows)
        self._flush_if_due(run)

    # -- stop --------------------------------------------------------------------
    @layout.locked
    def stop(self, doc: RunStop) -> Path:
        """Write end time, sample count and the stop event, then the final status; close."""
        run = self._run(doc.uid)
        if doc.status not in RUN_STATUSES or doc.status == "running":
            raise InputError(f"final status must be one of {RUN_STATUSES[1:]}, got {doc.status!r}",
                             file=str(run.path), field="status")
        payload = {"reason": doc.reason, "metadata": doc.metadata,
                   "n_samples_reported": int(doc.n_samples), "status": doc.status}
        self._finish(run, doc.status, doc.end_time or utc_now(), payload)
        del self._runs[doc.uid]
        self._catalog_add(run.path)
        return run.path

    def _finish(self, run: _OpenRun, status: str, end_time: str, payload: dict) -> None:
        try:
            e = run.ds("entry")
            rows = layout.event_rows("stop", status, run.n_written,
                                     layout.to_json(payload, field="stop.metadata"))
            layout.append_rows(run.ds("entry/acquisition/events"), rows)
            raw = end_time.encode()[:40]
            e["end_time"][()] = np.bytes_(raw)
            e["n_samples"][()] = run.n_written
            run.file.flush()
            e["status"][()] = np.bytes_(status.encode())  # last: a torn stop reads "running"
            run.file.flush()
        finally:
            run.file.close()
            OPEN_FOR_WRITE.discard(str(run.path.resolve()))

    # -- flushing / closing ------------------------------------------------------
    def _flush_if_due(self, run: _OpenRun) -> None:
        now = self.clock()
        if now - run.last_flush >= self.flush_interval_s:
            run.file.flush()
            run.last_flush = now

    @layout.locked
    def flush_if_due(self) -> None:
        """Flush every open run whose flush interval has passed."""
        for run in self._runs.values():
            self._flush_if_due(run)

    @layout.locked
    def flush(self) -> None:
        """Flush every open run now."""
        for run in self._runs.values():
            run.file.flush()
            run.last_flush = self.clock()

    @layout.locked
    def close(self) -> None:
        """Close runs that never got a RunStop; they are marked "incomplete"."""
        for uid, run in list(self._runs.items()):
            self._finish(run, "incomplete", utc_now(),
                         {"reason": "writer closed before RunStop", "status": "incomplete"})
            del self._runs[uid]
            self._catalog_add(run.path)

    def __enter__(self) -> "RunWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _catalog_add(self, path: Path) -> bool:
        """Index ``path``; on failure (catalog unreachable) one warning line, and the file
        is kept in :attr:`catalog_pending` (the file is the truth: the index follows)."""
        if self.catalog is None:
            return True
        try:
            self.catalog.add(path)
        except Exception as exc:
            why = one_line(exc)
            if path not in self.catalog_pending:
                log.warning("catalog update failed for %s: %s (the run file is kept; "
                            "`labjoint recover` indexes it)", path.name, why)
            self.catalog_pending[path] = why
            return False
        self.catalog_pending.pop(path, None)
        return True

    def retry_catalog(self) -> list[Path]:
        """Index the run files whose catalog update failed and are no longer written;
        returns those indexed now (the rest stay pending)."""
        open_now = set(self.open_paths)
        return [p for p in list(self.catalog_pending)
                if p not in open_now and self._catalog_add(p)]


def one_line(exc: BaseException) -> str:
    """An exception as one line (a database driver's errors span several)."""
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text.splitlines()[0] if text else ''}".rstrip(": ")

