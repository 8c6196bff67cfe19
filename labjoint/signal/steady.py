"""Steady-state detection from per-cycle amplitudes (and phase): drop transient cycles.

A cycle j is *in band* when its value is within tolerance of the level the run
settles to *around it*: the mean of a window of W cycles that starts W cycles after j
(or ends W cycles before j), moved to j along the run's drift rate. The drift rate is
the median of window-to-window slopes over the whole run, i.e. the settled rate, since
settled cycles are the majority. So a slow monotone drift (wear) is followed and never
called transient, while a fast settling (start from rest, ramp) or a trailing ramp-down
deviates from both windows and is. Tolerance: ``max(rel_tol |level|, abs_tol,
n_sigma noise)``, noise from successive-cycle differences (robust MAD) and
``n_sigma = sqrt(2 ln n) + 1`` so no cycle of a long steady run is out by chance.
The steady segment is the longest run of in-band cycles, bridging isolated out-of-band
cycles (at most ``max_gap`` in a row, themselves excluded from the mask). The median
slope is the settled rate only while settled cycles are the majority: a start-up
transient over half the record or more would set it, and its own cycles would pass as a
drift while the settled ones failed; so the segment is also found with no drift rate
(and noise from second differences, which a ramp does not enter), and the longer of the
two is kept.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from labjoint.errors import InputError

MIN_WINDOW, MAX_WINDOW = 3, 64


@dataclass(frozen=True)
class SteadyState:
    """Steady cycles ``start <= k < stop``; ``mask`` also drops bridged outliers."""

    start: int
    stop: int
    mask: np.ndarray
    window: int
    noise: dict[str, float] = field(default_factory=dict)
    note: str = ""

    @property
    def n_steady(self) -> int:
        return int(self.mask.sum())


def detect_steady(displacement_amplitude: np.ndarray, force_amplitude: np.ndarray | None = None,
                  phase: np.ndarray | None = None, *, rel_tol: float = 0.01,
                  phase_tol: float | None = None, valid: np.ndarray | None = None,
                  window: int | None = None, max_gap: int = 2) -> SteadyState:
    """Steady cycles of a run from per-cycle amplitudes (m, N) and phase (rad).

    ``phase`` (e.g. force-displacement lag) uses the absolute tolerance ``phase_tol``
    (default ``rel_tol`` rad: a complex ratio moves as much for a relative modulus
    change ``rel_tol`` as for an angle change of ``rel_tol`` rad). ``valid`` marks
    cycles usable at all. ``window`` defaults to clamp(n // 16, 3, 64) cycles.

    >>> k = np.arange(300)
    >>> s = detect_steady(1 - np.exp(-k / 4.0))
    >>> s.start, s.stop                       # exp(-k/4) < 1 % from k = 19
    (19, 300)
    """
    series = {"displacement_amplitude": displacement_amplitude,
              "force_amplitude": force_amplitude, "phase": phase}
    arrays = {k: np.asarray(v, dtype=np.float64) for k, v in series.items() if v is not None}
    n = arrays["displacement_amplitude"].size
    for name, arr in arrays.items():
        if arr.ndim != 1 or arr.size != n:
            raise InputError(f"must be 1-D with {n} cycles like displacement_amplitude, "
                             f"got shape {arr.shape}", field=name)
    if not (np.isfinite(rel_tol) and rel_tol > 0):
        raise InputError(f"must be finite and > 0, got {rel_tol!r}", field="rel_tol")
    ok = np.ones(n, bool) if valid is None else np.asarray(valid, bool).copy()
    if ok.shape != (n,):
        raise InputError(f"must have {n} entries, got shape {ok.shape}", field="valid")
    for arr in arrays.values():
        ok &= np.isfinite(arr)
    idx = np.flatnonzero(ok)
    w = int(window) if window is not None else int(np.clip(idx.size // 16, MIN_WINDOW, MAX_WINDOW))
    if w < 1:
        raise InputError(f"must be >= 1, got {window!r}", field="window")
    if idx.size < 4 * w:
        return _few(arrays, ok, idx, rel_tol, phase_tol, w, max_gap)
    best: tuple[int, int, np.ndarray, dict[str, float]] | None = None
    for drift in (True, False):
        band = np.ones(idx.size, bool)
        noise = {}
        for name, arr in arrays.items():
            is_phase = name == "phase"
            a = np.unwrap(arr[idx]) if is_phase else arr[idx]
            tol_abs = (rel_tol if phase_tol is None else float(phase_tol)) if is_phase else 0.0
            in_band, sigma = _in_band(a, 0.0 if is_phase else rel_tol, tol_abs, w, drift)
            band &= in_band
            noise[name] = sigma
        full = np.zeros(n, bool)
        full[idx] = band
        start, stop = _segment(full, max_gap)
        if best is None or stop - start > best[1] - best[0]:
            best = (start, stop, full, noise)
    start, stop, full, noise = best
    return SteadyState(start, stop, full & _span(n, start, stop), w, noise)


def _few(arrays: dict[str, np.ndarray], ok: np.ndarray, idx: np.ndarray, rel_tol: float,
         phase_tol: float | None, w: int, max_gap: int) -> SteadyState:
    """Too few cycles for the windows: each cycle against the median of all valid ones
    (the settled cycles are the majority), tolerance max(rel_tol |median|, n_sigma x the
    cycles' robust scatter about it); a start-up ramp's cycles are out of band, a steady
    run's (however noisy) are all in. Keeping every cycle instead let a short record's
    ramp-up pass as steady: its off-centre loop moved the displacement zero and the
    record was primed as if steady from its start."""
    n = ok.size
    full = np.zeros(n, bool)
    if idx.size < 3:
        full[idx] = True
    else:
        band = np.ones(idx.size, bool)
        for name, arr in arrays.items():
            is_phase = name == "phase"
            a = np.unwrap(arr[idx]) if is_phase else arr[idx]
            level = float(np.median(a))
            sigma = 1.4826 * float(np.median(np.abs(a - level)))   # the cycles' own scatter
            noise_tol = (np.sqrt(2.0 * np.log(max(a.size, 2))) + 1.0) * sigma
            tol = (rel_tol if phase_tol is None else float(phase_tol)) if is_phase \
                else rel_tol * abs(level)
            band &= np.abs(a - level) <= max(tol, noise_tol)
        full[idx] = band
    start, stop = _segment(full, max_gap)
    return SteadyState(start, stop, full & _span(n, start, stop), w,
                       note=f"only {idx.size} valid cycles: too few for the windows, each judged "
                            "against their median")


def _in_band(a: np.ndarray, rel_tol: float, abs_tol: float, w: int,
             drift: bool = True) -> tuple[np.ndarray, float]:
    """Per-cycle: is ``a`` within tolerance of the drift-corrected level W cycles away?
    (``drift=False``: of the level itself, no drift rate.)"""
    n = a.size
    cs = np.concatenate([[0.0], np.cumsum(a)])
    means = (cs[w:] - cs[:-w]) / w                       # means[s] = mean(a[s:s+w])
    slope = float(np.median((means[w:] - means[:-w]) / w)) if drift else 0.0
    reach = w + (w - 1) / 2.0                            # from j to the window centre
    m = max(n - 2 * w + 1, 0)                           # cycles with a window after them
    after = np.full(n, np.nan)
    after[:m] = means[w:w + m] - slope * reach           # a[j] vs mean(a[j+w:j+2w])
    before = np.full(n, np.nan)
    before[2 * w:] = means[:max(n - 2 * w, 0)] + slope * reach   # vs mean(a[j-2w:j-w])
    second = not drift and n > 2                         # then a ramp is not noise either
    d = np.diff(a, 2 if second else 1)
    sigma = float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(6.0 if second else 2.0))
    n_sigma = np.sqrt(2.0 * np.log(max(n, 2))) + 1.0
    noise_tol = n_sigma * sigma * np.sqrt(1.0 + 1.0 / w)
    result = np.zeros(n, bool)
    for level in (after, before):
        have = np.isfinite(level)
        tol = np.maximum(np.maximum(rel_tol * np.abs(level[have]), abs_tol), noise_tol)
        result[have] |= np.abs(a[have] - level[have]) <= tol
    return result, sigma


def _segment(band: np.ndarray, max_gap: int) -> tuple[int, int]:
    """Longest run of True, bridging runs of at most ``max_gap`` False (earliest wins)."""
    on = np.flatnonzero(band)
    if on.size == 0:
        return 0, 0
    breaks = np.flatnonzero(np.diff(on) > max_gap + 1)
    starts = np.concatenate([[on[0]], on[breaks + 1]])
    stops = np.concatenate([on[breaks], [on[-1]]]) + 1
    best = int(np.argmax(stops - starts))
    return int(starts[best]), int(stops[best])


def _span(n: int, start: int, stop: int) -> np.ndarray:
    m = np.zeros(n, bool)
    m[start:stop] = True
    return m
