"""Runs prepared for model comparison: model inputs, steady samples, cycles, loop results.

A run comes from an HDF5 run file, a CSV file in the import format (design.md) or a
:class:`~labjoint.storage.run.Run` already in memory. Its steady state and cycles come
from the hysteresis-loop pipeline (:func:`labjoint.identify.analyze_run`: cycle
boundaries at the displacement fundamental's upward zero crossings, steady cycles by
drift-following detection); the comparison uses whole steady cycles only.

Steady cycles: those of the loop pipeline, minus windows of cycles whose force scatters
from cycle to cycle more than measurement noise allows (a passing transient, e.g. a rig
mode ringing after a start from rest; :func:`labjoint.compare.noise.stationary_cycles`).

Displacement zero. A DC-coupled displacement sensor reads its gap as well as the joint's
motion; spring, cubic and gap laws need the joint's own zero. The reference subtracted
(:func:`displacement_reference`, kept as ``displacement_reference_m`` in the metadata) is
the rest position when the record begins at rest, else the centre of the steady loops.

History. Every hysteretic model state starts relaxed at the first sample it is given
(:mod:`labjoint.models.inputs`). A record that begins with a transient (the rig started
from rest within it, steady state detected later) already holds the joint's history, so it
is used as it is; a record that is steady from its first cycle (acquired after the
engine's wait for steady state) is cropped to start at its first steady cycle and
primed: its first steady cycle, continued backwards periodically for ``PRIME_CYCLES``
periods, with an amplitude envelope rising smoothly from zero about the cycle's centre
(midpoint of its displacement extremes) over the first ``PRIME_RAMP`` of them. Like the
rig's own ramp-up, this starts the model relaxed at the loop's centre and grows centred
loops, so it reaches the centred steady loop whatever the phase at which the record
begins (a plain periodic continuation would relax the model wherever the continuation
starts, off centre by up to a sample of travel, and shift its loop's mean force).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from scipy.interpolate import CubicSpline

from labjoint.errors import InputError
from labjoint.identify import LoopResult, analyze_run
from labjoint.identify.plausible import Plausibility, refuse_large_record
from labjoint.compare.noise import stationary_cycles
from labjoint.compare.prepared import PreparedRun
from labjoint.models import ModelInputs, RunData
from labjoint.signal.mains import remove_mains
from labjoint.storage import Run, read_any

M = TypeVar("M")
PRIME_CYCLES = 5
REST_FRACTION = 0.1
REST_SAMPLES = 8
#: a head whose quadratic trend spans more than this many residual standard deviations
#: moves (its zero is the trend at the first instant); else it rests (its mean)
MOVING_SIGMAS = 10.0
PRIME_RAMP = 3


def steady_cycles(run: Run, loop: LoopResult) -> tuple[np.ndarray, int, bool]:
    """Loop-pipeline steady cycles with interpolation neighbours inside the record, minus
    the windows whose force scatter shows a passing transient
    (:func:`labjoint.compare.noise.stationary_cycles`): (cycle indices, cycles left out,
    whether the record begins with a transient)."""
    b = loop.bounds
    n = len(run.time)
    ks = np.flatnonzero(loop.steady)
    ks = ks[(b[ks] >= 1.0) & (b[ks + 1] <= n - 3)]
    if ks.size == 0:
        return ks, 0, False
    groups = np.split(ks, np.flatnonzero(np.diff(ks) > 1) + 1)
    keep = stationary_cycles(np.asarray(run.force, dtype=float), [b[g[0]:g[-1] + 2] for g in groups])
    kept = np.concatenate([g[k] for g, k in zip(groups, keep)])
    start = int(loop.steady_state.start) >= 1 or (kept.size > 0 and kept[0] > ks[0])
    return kept, int(ks.size - kept.size), bool(start)


def prepare_run(run: Run | str | Path, *, prime_cycles: int | str = "auto",
                band_hz: float | None = None, min_cycles: int = 3,
                plausibility: Plausibility | None = None) -> PreparedRun:
    """Prepare one run: loop pipeline, steady cycles, model inputs (priming: module doc).

    ``prime_cycles``: "auto" (module doc) or a number of cycles to prepend;
    ``plausibility``: the limits of :mod:`labjoint.identify.plausible` (the displacement
    cap checked on the samples before the loop pipeline).
    """
    if isinstance(run, (str, Path)):
        run = read_any(run)
    if not isinstance(run, Run):
        raise InputError(f"expected a run file path or a Run, got {type(run).__name__}", field="runs")
    where = run.path or run.name
    refuse_large_record(run.displacement, plausibility, f"run '{run.name}': ")
    run, hum = _without_mains(run)
    try:
        loop = analyze_run(run, min_cycles=min_cycles, plausibility=plausibility)
    except InputError as exc:
        raise InputError(f"run '{run.name}': {exc.message}", file=run.path,
                         field=exc.field) from None
    n = len(run.time)
    ids, transient, begins_transient = steady_cycles(run, loop)
    if ids.size < min_cycles:
        raise InputError(f"run '{run.name}' has {ids.size} usable steady cycles; at least "
                         f"{min_cycles} are needed", file=where, field="steady")
    spans = np.column_stack([np.ceil(loop.bounds[ids]), np.ceil(loop.bounds[ids + 1])]).astype(np.int64)
    keep = np.zeros(n, bool)
    for a, b in spans:
        keep[a:b] = True
    if prime_cycles == "auto":
        prime = 0 if begins_transient else PRIME_CYCLES
    else:
        try:
            prime = int(prime_cycles)
        except (TypeError, ValueError):
            raise InputError(f"must be 'auto' or a number, got {prime_cycles!r}",
                             field="prime_cycles") from None
        if prime < 0:
            raise InputError("must be >= 0", field="prime_cycles")
    md = dict(run.metadata)
    if hum:
        md["mains_removed"] = hum
    md.setdefault("frequency_hz", loop.frequency_hz)
    f = float(loop.frequency_hz)
    fs = float(run.sample_rate_hz)
    u_all = np.asarray(run.displacement, dtype=float)
    ref = displacement_reference(u_all, spans, at_start=prime == 0)
    md["displacement_reference_m"] = ref
    u_all = u_all - ref
    if prime == 0:
        data = RunData.from_arrays(u_all, run.force, fs, steady=keep, frequency_hz=f,
                                   name=run.name, band_hz=band_hz, metadata=md)
        return PreparedRun(run.name, data, loop, ids, spans, 0, 0, transient, run.path, md)
    off = int(spans[0, 0])
    u = u_all[off:]
    per = float(loop.bounds[ids[0] + 1] - loop.bounds[ids[0]])
    head = ramped_prime(u, per, prime)
    full = ModelInputs.from_record(np.concatenate([head, u]), fs, frequency_hz=f, name=run.name,
                                   band_hz=band_hz, metadata=md)
    inputs = replace(full, n_prime=head.size)
    data = RunData(inputs, np.asarray(run.force[off:], dtype=float), keep[off:])
    return PreparedRun(run.name, data, loop, ids, spans - off, prime, off, transient, run.path, md)


def _without_mains(run: Run) -> tuple[Run, dict[str, list[dict[str, float]]]]:
    """The run with mains hum taken off force and displacement
    (:func:`labjoint.signal.mains.remove_mains`), and the lines removed per channel."""
    fs = float(run.sample_rate_hz)
    F = np.asarray(run.force, dtype=float)
    drive = run.frequency_hz
    if not drive:
        spec = np.abs(np.fft.rfft((F - F.mean()) * np.hanning(F.size)))
        freqs = np.fft.rfftfreq(F.size, 1.0 / fs)
        spec[freqs < 20.0] = 0.0
        drive = float(freqs[int(np.argmax(spec))]) or None
    force, lf = remove_mains(F, fs, drive)
    disp, ld = remove_mains(np.asarray(run.displacement, dtype=float), fs, drive)
    hum = {k: [line.to_dict() for line in v] for k, v in (("force", lf), ("displacement", ld)) if v}
    if not hum:
        return run, {}
    return replace(run, force=force, displacement=disp), hum


def displacement_reference(u: np.ndarray, spans: np.ndarray, at_start: bool) -> float:
    """The displacement the joint is at rest at, subtracted before modelling (a DC-coupled
    displacement sensor reads its gap, an arbitrary offset; spring, cubic and gap laws need
    the joint's own zero): the record's first instant when it begins at rest (moving by
    less than ``REST_FRACTION`` of the steady amplitude over its first eighth of a period;
    a quadratic through those samples at t = 0 when its trend spans more than
    ``MOVING_SIGMAS`` residual standard deviations, else the mean of the first
    ``REST_SAMPLES``),
    else the centre of the steady loops (mean midpoint of each cycle's extremes)."""
    mids, amps = [], []
    for a, b in spans:
        seg = u[a:b]
        mids.append(0.5 * (seg.max() + seg.min()))
        amps.append(0.5 * (seg.max() - seg.min()))
    centre, amp = float(np.mean(mids)), float(np.mean(amps))
    if at_start:
        per = float(np.median(spans[:, 1] - spans[:, 0]))
        head = u[:max(REST_SAMPLES, int(per / 8))]
        if np.ptp(head) < REST_FRACTION * amp:
            # the first instant, by a quadratic through the head: a start from rest moves
            # off its rest value at once (as t^2 under a ramped sine), so the mean of the
            # head sat off it by ~1 % of the amplitude at 57 samples per cycle, which a
            # cubic spring turns into an even harmonic of 2-3 % of the force
            x = np.arange(head.size, dtype=float)
            coef = np.polynomial.polynomial.polyfit(x, head, 2)
            trend = np.polynomial.polynomial.polyval(x, coef)
            if abs(trend[-1] - trend[0]) > MOVING_SIGMAS * float(np.std(head - trend)):
                return float(coef[0])
            # no clear motion: the mean (a quadratic's intercept scatters more)
            return float(np.mean(head[:REST_SAMPLES]))
    return centre


def ramped_prime(u: np.ndarray, per: float, cycles: int, ramp: int = PRIME_RAMP) -> np.ndarray:
    """``cycles`` periods of ``u``'s first cycle continued backwards (cubic, continuous
    into u[0]), with a raised-cosine envelope from 0 to 1 over the first ``ramp`` periods
    about the cycle's centre (module docstring)."""
    k = int(np.ceil(per)) + 4
    if u.size < k:
        raise InputError(f"priming needs one full cycle ({k} samples)", field="steady")
    m = int(round(cycles * per))
    pos = np.mod(np.arange(-m, 0, dtype=float), per)
    x = CubicSpline(np.arange(k, dtype=float), u[:k])(pos)
    seg = u[:int(np.ceil(per))]
    centre = 0.5 * (seg.max() + seg.min())
    t = np.arange(m) / (min(ramp, cycles) * per)
    env = np.where(t < 1.0, 0.5 - 0.5 * np.cos(np.pi * np.clip(t, 0.0, 1.0)), 1.0)
    return centre + env * (x - centre)


def prepare_runs(runs: Iterable[Run | str | Path | PreparedRun], **kwargs: Any) -> list[PreparedRun]:
    """Prepare every run (already prepared ones pass through); names made unique."""
    out: list[PreparedRun] = []
    for r in runs:
        out.append(r if isinstance(r, PreparedRun) else prepare_run(r, **kwargs))
    if not out:
        raise InputError("no runs given", field="runs")
    seen: dict[str, int] = {}
    for i, r in enumerate(out):
        seen[r.name] = seen.get(r.name, 0) + 1
        if seen[r.name] > 1:
            new = f"{r.name}#{seen[r.name]}"
            out[i] = r.renamed(new)
    return out


def default_split(runs: Sequence[PreparedRun], every: int = 3
                  ) -> tuple[list[PreparedRun], list[PreparedRun], str]:
    """(fit runs, validation runs, rule): hold out the highest frequency when the set has
    two or more (frequency-dependent effects are judged by extrapolation in frequency,
    seed 000: fit on one mode, validate on another); with one frequency, every ``every``-th
    run in order of amplitude among all but the smallest and the largest (both ends stay in
    the fit), starting from the second smallest."""
    freqs = np.array([r.frequency_hz for r in runs])
    levels = _levels(freqs)
    if len(runs) < 2:
        raise InputError("at least two runs are needed to fit on some and validate on others",
                         field="runs")
    if levels.max() >= 1:
        top = levels == levels.max()
        fit = [r for r, t in zip(runs, top) if not t]
        val = [r for r, t in zip(runs, top) if t]
        f = float(np.median(freqs[top]))
        return fit, val, f"validation: the highest frequency ({f:g} Hz), held out"
    return split_every_nth(runs, [r.amplitude_m for r in runs], every,
                           "by amplitude (one frequency only)")


def split_every_nth(ms: Sequence[M], keys: Sequence[float], every: int = 3,
                    what: str = "by amplitude") -> tuple[list[M], list[M], str]:
    """(fit, validation, rule): every ``every``-th measurement in order of ``keys`` among
    all but the smallest and the largest (both ends stay in the fit), starting from the
    second smallest."""
    if len(ms) < 2:
        raise InputError("at least two runs are needed to fit on some and validate on others",
                         field="runs")
    order = np.argsort(np.asarray(keys, dtype=float), kind="stable")
    pick = np.zeros(len(ms), bool)
    inner = order[1:-1] if len(ms) > 2 else order[1:]
    k = max(int(every), 2)
    pick[inner[::k]] = True
    fit = [r for r, p in zip(ms, pick) if not p]
    val = [r for r, p in zip(ms, pick) if p]
    nth = {2: "2nd", 3: "3rd"}.get(k, f"{k}th")
    return fit, val, f"validation: every {nth} run {what}"


def _levels(freqs: np.ndarray, rel: float = 0.02) -> np.ndarray:
    """Frequency class of each run (0, 1, ...): frequencies within ``rel`` are one class."""
    order = np.argsort(freqs)
    lev = np.zeros(freqs.size, np.int64)
    k = 0
    for i in range(1, freqs.size):
        if freqs[order[i]] > freqs[order[i - 1]] * (1 + rel):
            k += 1
        lev[order[i]] = k
    return lev


def frequency_levels(runs: Sequence[PreparedRun]) -> np.ndarray:
    """Frequency class per run (runs within 2 % share one)."""
    return _levels(np.array([r.frequency_hz for r in runs]))


def split_by_names(runs: Sequence[PreparedRun], validate: Sequence[str | Path]
                   ) -> tuple[list[PreparedRun], list[PreparedRun], str]:
    """(fit, validation, rule) with the validation runs named (run name, file name or path)."""
    keys = {str(v) for v in validate} | {Path(str(v)).stem for v in validate} \
        | {str(Path(str(v)).resolve()) for v in validate}
    val, fit = [], []
    for r in runs:
        ids = {r.name}
        if r.path:
            ids |= {r.path, Path(r.path).stem, str(Path(r.path).resolve())}
        (val if ids & keys else fit).append(r)
    if not val:
        raise InputError(f"none of {list(map(str, validate))} is among the runs", field="validate")
    if not fit:
        raise InputError("every run is a validation run; leave some to fit", field="validate")
    return fit, val, "validation: runs named by --validate"
