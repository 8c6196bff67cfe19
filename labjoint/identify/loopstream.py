"""The streaming half of the hysteresis-loop pipeline: checked blocks in, per-cycle
metrics out.

:func:`checked_blocks` validates each (displacement, force) block (finite, same length,
not clipped); :class:`LoopStream` runs filter -> cycle boundaries -> per-cycle loop
metrics block by block, the front half (zero-phase low-pass of seed 002, cycle
segmentation) in a helper thread while the back half measures the cycles of the block
before, holding only a chunk plus a cycle. :mod:`labjoint.identify.analyze` assembles
the result (steady state, summary, resolution, plausibility).
"""

from __future__ import annotations

from concurrent.futures import Future
from typing import Any, Iterable, Iterator

import numpy as np

from labjoint.errors import InputError
from labjoint.identify.loop import loop_metrics
from labjoint.signal import validate
from labjoint.signal.clipping import refuse_clipped
from labjoint.signal.filter import ZeroPhaseStream
from labjoint.signal.phase import CycleSegmenter
from labjoint.signal.prefetch import helper_pool


def checked_blocks(blocks: Iterable[Any]) -> Iterator[np.ndarray]:
    """Each block as a validated float (2, n) array, not clipped; errors name the block."""
    for i, blk in enumerate(blocks):
        if isinstance(blk, np.ndarray) and blk.ndim == 2:
            if blk.shape[0] != 2:
                raise InputError(f"must be (displacement, force): 2 rows, got shape "
                                 f"{blk.shape}", field=f"blocks[{i}]")
            u, F = blk[0], blk[1]
        else:
            try:
                u, F = blk
            except (TypeError, ValueError):
                raise InputError("must be a (displacement, force) pair or a (2, n) array",
                                 field=f"blocks[{i}]") from None
        u = validate.signal(u, f"blocks[{i}].displacement", min_samples=0)
        F = validate.signal(F, f"blocks[{i}].force", min_samples=0)
        validate.same_length(F, u, f"blocks[{i}].force", "displacement")
        refuse_clipped(u, "displacement"), refuse_clipped(F, "force", reference=u)
        if u.size:
            yield blk if isinstance(blk, np.ndarray) and blk.dtype == np.float64 \
                else np.stack([u, F])


class LoopStream:
    """Filter -> segment -> resample -> per-cycle metrics, one block at a time."""

    def __init__(self, fs: float, f: float, cutoff: float | None, order: int,
                 n_points: int, n_harmonics: int, threads: bool = True) -> None:
        self.fs, self.f, self.n_points, self.n_harmonics = fs, f, n_points, n_harmonics
        self.threads = threads
        self.filter = ZeroPhaseStream(fs, cutoff, order) if cutoff is not None else None
        self.seg = CycleSegmenter(fs, f)
        self.buf = np.empty((2, 0))
        self.buf_start = 0
        self.pending = np.empty(0)          # boundaries not yet closed into a cycle
        self.used: list[np.ndarray] = []
        self.parts: list[dict[str, np.ndarray]] = []
        self.n_samples = 0
        self._settled = 0.0

    def run(self, blocks: Iterable[np.ndarray]) -> None:
        """Push every block; the front half (low-pass and cycle boundaries) of block k+1
        runs in a second thread while the cycles of block k are measured (the compiled
        filter and demodulation release the GIL), so the two halves overlap on a
        multi-core machine. At most two blocks are in flight, so memory stays bounded."""
        with helper_pool(self.threads, "labjoint-loop") as pool:
            pending: Future | None = None
            for blk in blocks:
                self.n_samples += blk.shape[1]
                nxt = pool.submit(self._front, blk)
                if pending is not None:
                    self._take(*pending.result())
                pending = nxt
            if pending is not None:
                self._take(*pending.result())

    def finish(self) -> tuple[dict[str, np.ndarray], np.ndarray]:
        if self.filter is not None:
            self._take(*self._segment(self.filter.finish()))
        self.pending = np.concatenate([self.pending, self.seg.finish()])
        self._settled = self.seg.settled_index
        self._process()
        if not self.parts:
            return {}, self.pending[:1]
        per_cycle = {k: np.concatenate([p[k] for p in self.parts]) for k in self.parts[0]}
        bounds = np.concatenate([u[:-1] for u in self.used] + [self.used[-1][-1:]])
        return per_cycle, bounds

    def _front(self, block: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """:meth:`_segment` of the filtered samples of ``block`` that are now final."""
        return self._segment(self.filter.push(block) if self.filter is not None else block)

    def _segment(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """``y``, the cycle boundaries it closes, and the index before which no later
        boundary can fall (taken here, with the boundaries, since the segmenter runs
        ahead of :meth:`_take` in the pipeline)."""
        bounds = self.seg.push(y[0]) if y.size else np.empty(0)
        return y, bounds, self.seg.settled_index

    def _take(self, y: np.ndarray, bounds: np.ndarray, settled: float) -> None:
        if y.size == 0:
            return
        self.pending = np.concatenate([self.pending, bounds])
        self._settled = settled
        if self.buf.shape[1]:
            # the cycles that straddle the held samples and y are measured on a short
            # joined copy; what is still needed then usually lies in y alone (no copy)
            y_start = self.buf_start + self.buf.shape[1]
            head = min(y.shape[1], 2 * int(np.ceil(self.fs / self.f)) + 8)
            self.buf = np.concatenate([self.buf, y[:, :head]], axis=1)
            self._process()
            if self.buf_start >= y_start:
                self.buf = y[:, self.buf_start - y_start:]
            else:
                self.buf = np.concatenate([self.buf, y[:, head:]], axis=1)
        else:
            self.buf = y
        self._process()

    def _process(self) -> None:
        end = self.buf_start + self.buf.shape[1]
        nb = int(np.searchsorted(self.pending, end - 3, side="right"))
        if nb >= 2:
            b = self.pending[:nb]
            metrics = loop_metrics(self.buf[0], self.buf[1], b, self.f, self.n_points,
                                   self.n_harmonics, offset=self.buf_start)
            metrics["cycle_frequency"] = self.fs / np.diff(b)
            self.parts.append(metrics)
            self.used.append(b)
            self.pending = self.pending[nb - 1:]
        keep = self._settled if self.pending.size == 0 else self.pending[0]
        cut = int(np.floor(keep)) - 2 - self.buf_start
        if cut > 0:
            self.buf = self.buf[:, cut:]
            self.buf_start += cut
