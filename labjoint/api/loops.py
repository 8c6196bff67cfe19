"""The hysteresis loops of a run's steady cycles, for plotting (``GET /runs/{name}/loops``).

The run goes through the hysteresis-loop pipeline as ``labjoint analyze`` runs it (seed
002 Sec. II.A: zero-phase Butterworth low-pass, cycles from the phase of the
displacement's fundamental, per-cycle loop quantities of Eq. 1, steady-state detection),
streamed a block at a time. The chosen steady cycles are then read again with a margin
of the filter's settling length on each side (the overlap the streaming filter uses), so
filtering that stretch gives the samples the pipeline saw, and each cycle is resampled
over exactly one period from its start (the fundamental's upward zero crossing) to at
most ``points_per_cycle`` points. Per-cycle energy loss and stiffness are the pipeline's
own numbers. A finished run goes through :func:`labjoint.identify.analyze.analyze_file`,
exactly as ``labjoint analyze`` runs it: a record that is not a steady sine (a multisine,
a sweep) or has a clipped channel is refused with the pipeline's own message and no loop
is drawn (issue 33 item 1); a run still being recorded streams through
:func:`~labjoint.identify.analyze.analyze_blocks`. Every stored channel is also checked
for flat tops (:mod:`labjoint.api.clipped`) so the page can warn
of a clipped one whichever pipeline looks at it. Analyses are kept in a small cache keyed
by the file's identity and length, so a page coming back to a run does not rerun it.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from typing import Any

import numpy as np

from labjoint.api.analysis import loop_blocks
from labjoint.api.clipped import clipped_channels, file_key
from labjoint.api.resolve import roles
from labjoint.errors import InputError
from labjoint.identify.analyze import analyze_blocks, analyze_file
from labjoint.identify.loop import LoopResult
from labjoint.signal.cycles import cycles
from labjoint.signal.filter import PAPER_CUTOFF_HZ, PAPER_ORDER, butter_sos, lowpass, settling_samples
from labjoint.storage import RunFile

#: Fewest points a cycle is drawn with.
MIN_POINTS = 8
#: Most samples read back for the cycles returned (fewer, later cycles beyond it).
MAX_SPAN_SAMPLES = 2_000_000
#: Analyses kept (one LoopResult per run file state: a few hundred bytes per cycle).
CACHE_SIZE = 32


class _Cache:
    """A small thread-safe LRU of loop analyses."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._d: OrderedDict[tuple[Any, ...], Any] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: tuple[Any, ...]) -> Any:
        with self._lock:
            hit = self._d.get(key)
            if hit is not None:
                self._d.move_to_end(key)
            return hit

    def put(self, key: tuple[Any, ...], value: Any) -> None:
        with self._lock:
            self._d[key] = value
            self._d.move_to_end(key)
            while len(self._d) > self.size:
                self._d.popitem(last=False)


_CACHE = _Cache(CACHE_SIZE)


def analysis(rf: RunFile, force: str = "joint") -> LoopResult:
    """The loop pipeline's result on the open run (``labjoint analyze``'s defaults); an
    InputError (cached too) when the pipeline refuses the run."""
    key = file_key(rf, force)
    hit = _CACHE.get(key)
    if hit is None:
        try:
            if rf.status == "running":
                hit = analyze_blocks(loop_blocks(rf, force), rf.sample_rate_hz,
                                     rf.frequency_hz, PAPER_CUTOFF_HZ)
            else:
                hit = analyze_file(rf.path, force=force)
        except InputError as exc:
            hit = exc
        _CACHE.put(key, hit)
    if isinstance(hit, InputError):        # a fresh one: several requests may see it
        raise InputError(hit.message, file=hit.file, line=hit.line, column=hit.column,
                         field=hit.field)
    return hit


def _filtered(rf: RunFile, force: str, a: int, b: int, cutoff: float | None) -> np.ndarray:
    """(displacement m, force N) of samples ``a:b``, low-passed as the pipeline does."""
    r = roles(rf)
    disp, fch = r["displacement"], r["force" if force == "joint" else "reference_force"]
    u = rf.physical(disp[0], a, b)
    if len(disp) == 2:
        u = u - rf.physical(disp[1], a, b)
    x = np.stack([u, rf.physical(fch[0], a, b)])
    return x if cutoff is None else lowpass(x, rf.sample_rate_hz, cutoff, PAPER_ORDER)


def _finite(v: Any) -> float | None:
    x = float(v)
    return x if math.isfinite(x) else None


def empty(rf: RunFile, reason: str, **extra: Any) -> dict[str, Any]:
    """The answer for a run with no steady cycle to show, saying why."""
    return {"run": rf.name, "status": rf.status, "complete": rf.status != "running",
            "n_samples": rf.n_samples, "sample_rate_hz": rf.sample_rate_hz,
            "frequency_hz": rf.frequency_hz, "cutoff_hz": None, "n_cycles": 0, "n_steady": 0,
            "steady_start": None, "steady_stop": None, "points_per_cycle": 0, "cycles": [],
            "summary": {}, "reason": reason, "refused": None, "clipped": [], "warnings": [],
            **extra}


def steady_loops(rf: RunFile, points_per_cycle: int = 128, max_cycles: int = 8,
                 force: str = "joint") -> dict[str, Any]:
    """The last ``max_cycles`` steady cycles of the open run (spanning at most
    ``MAX_SPAN_SAMPLES``), each resampled to at most ``points_per_cycle`` points (fewer
    when a cycle holds fewer samples), with their loop quantities; an empty list and the
    reason when there is none."""
    clipped = clipped_channels(rf) if rf.status != "running" else []
    try:
        res = analysis(rf, force)
    except InputError as exc:
        where = f"{exc.field} " if exc.field else ""
        refused = exc.field if exc.field == "excitation" or "clipped" in exc.message else None
        if refused:
            return empty(rf, f"refused by the loop pipeline: {where}{exc.message}",
                         refused=refused, clipped=clipped)
        return empty(rf, f"no steady cycles: {where}{exc.message}", clipped=clipped)
    md = res.metadata
    base = empty(rf, "", clipped=clipped, frequency_hz=res.frequency_hz, cutoff_hz=md.get("cutoff_hz"),
                 n_samples=md.get("n_samples", rf.n_samples), n_cycles=res.n_cycles,
                 n_steady=int(res.steady.sum()), steady_start=md.get("steady_start"),
                 steady_stop=md.get("steady_stop"), warnings=list(md.get("warnings", [])),
                 summary={k: _finite(v) for k, v in res.summary.items()})
    idx = np.flatnonzero(res.steady)[-max_cycles:]
    if idx.size == 0:
        base["reason"] = "no steady cycles: " + (md.get("steady_note") or "none found")
        return base
    fs, bounds = res.sample_rate_hz, res.bounds
    first = int(np.searchsorted(bounds[idx], bounds[idx[-1] + 1] - MAX_SPAN_SAMPLES))
    idx = idx[min(first, idx.size - 1):]
    per = float(np.median(np.diff(bounds[idx[0]:idx[-1] + 2])))
    m = int(min(points_per_cycle, max(MIN_POINTS, math.ceil(per))))
    cutoff = md.get("cutoff_hz")
    margin = 3 + (settling_samples(butter_sos(fs, cutoff, PAPER_ORDER)) if cutoff else 0)
    a = max(0, int(math.floor(bounds[idx[0]])) - margin)
    b = min(int(md.get("n_samples", rf.n_samples)), int(math.ceil(bounds[idx[-1] + 1])) + margin)
    x = _filtered(rf, force, a, b, cutoff)
    # consecutive steady cycles share bounds; resample each cycle on its own bounds
    starts, stops = bounds[idx], bounds[idx + 1]
    t0 = float(rf.time(0, 1)[0]) if rf.n_samples else 0.0
    out = []
    for k, s0, s1 in zip(idx, starts, stops):
        cyc = cycles(x, np.array([s0, s1]), m, offset=a)[:, 0, :]
        out.append({
            "index": int(k), "start_s": t0 + float(s0) / fs,
            "frequency_hz": _finite(res.cycle_frequency[k]),
            "displacement_amplitude_m": _finite(res.displacement_amplitude[k]),
            "force_amplitude_n": _finite(res.force_amplitude[k]),
            "energy_loss_j": _finite(res.energy_loss[k]),
            "energy_loss_uncertainty_j": _finite(res.energy_loss_uncertainty[k]),
            "below_resolution": bool(res.below_resolution[k]),
            "damping_ns_per_m": _finite(res.damping[k]),
            "stiffness_n_per_m": _finite(res.stiffness[k]),
            "stiffness_secant_n_per_m": _finite(res.stiffness_secant[k]),
            "displacement_m": cyc[0], "force_n": cyc[1]})
    base.update(points_per_cycle=m, cycles=out, reason=None)
    return base

