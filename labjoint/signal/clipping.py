"""Flat tops: a channel whose input range was exceeded (clipped, saturated ADC).

A saturated converter returns the same code sample after sample, so a clipped channel
sits at exactly one value, its extreme, for a stretch of each cycle; a measured signal
that is not clipped never repeats its extreme for several samples in a row (noise,
quantisation steps). Two look-alikes are told apart:

- coarse quantisation: a sine a few hundred codes high dwells at its top code for a few
  samples too, but then dwells longer still on the codes just below (a clipped channel
  passes those quickly: it is cut where it still moves fast);
- a Coulomb slider (Jenkins element, gross slip): the joint force is exactly constant
  while the joint slides, a real plateau; it ends where the displacement reverses (the
  slider sticks at once), whereas a clip of the force straddles the displacement's
  extreme (the force peaks near it) and is left again on the way back.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from labjoint.errors import InputError

#: Consecutive samples at the extreme that make a flat top.
MIN_RUN = 3
#: Fraction of the samples in flat tops above which a channel counts as clipped.
MIN_FRACTION = 0.002
#: Width of the band just below the extreme (fraction of the peak-to-peak range) that a
#: quantised, unclipped signal dwells in longer than at the extreme itself.
BAND = 0.01
#: A force plateau that lasts more than this many samples past the displacement's
#: reversal is a clip (a slider's plateau ends at the reversal sample).
AFTER_REVERSAL = 2


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) of the runs of True in ``mask``."""
    d = np.diff(mask.astype(np.int8), prepend=0, append=0)
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def flat_top_fraction(x: np.ndarray, reference: np.ndarray | None = None) -> tuple[float, float]:
    """(fraction of samples in flat tops at the maximum and minimum of ``x``, the level of
    the larger).

    With ``reference`` (the displacement, for a force channel), a flat top the reference
    does not reverse inside (a slider's plateau) is not counted.

    >>> t = np.arange(20000) / 20000.0
    >>> x = np.sin(2 * np.pi * 100 * t + 0.3)
    >>> flat_top_fraction(x)[0]
    0.0
    >>> round(float(flat_top_fraction(np.clip(x, -0.8, 0.8))[0]), 2)
    0.41
    """
    x = np.asarray(x, float)
    if x.size < MIN_RUN:
        return 0.0, float("nan")
    hi, lo = float(x.max()), float(x.min())
    span = hi - lo
    if not span > 0:
        return 0.0, float("nan")
    tol = 1e-9 * max(span, abs(hi), abs(lo))
    total, worst, level = 0, 0, float("nan")
    # both counts in one compiled pass, no mask: the common case (one sample at each
    # extreme) ends here; the masks are made only for a channel that may be clipped
    counts = _count_at_extremes(x, hi - tol, lo + tol) if x.ndim == 1 else (
        int(np.count_nonzero(x >= hi - tol)), int(np.count_nonzero(x <= lo + tol)))
    for ext, sign, n_at in ((hi, 1.0, counts[0]), (lo, -1.0, counts[1])):
        if n_at < MIN_RUN:                               # the common case: one sample
            continue
        at = x >= ext - tol if sign > 0 else x <= ext + tol
        band = int(np.count_nonzero(sign * (ext - x) <= BAND * span)) - n_at
        if band >= n_at:                                 # quantisation, not a clip
            continue
        starts, stops = _runs(at)
        long = (stops - starts) >= MIN_RUN
        n = 0
        for a, b in zip(starts[long], stops[long]):
            if reference is not None and not _reverses(reference[a:b]):
                continue
            n += b - a
        total += n
        if n > worst:
            worst, level = n, ext
    return total / x.size, level


@njit(cache=True, nogil=True)
def _count_at_extremes(x, hi_from, lo_to):  # pragma: no cover - compiled
    """Samples of ``x`` at or above ``hi_from`` and at or below ``lo_to``."""
    n_hi = 0
    n_lo = 0
    for i in range(x.size):
        n_hi += 1 if x[i] >= hi_from else 0
        n_lo += 1 if x[i] <= lo_to else 0
    return n_hi, n_lo


def _reverses(d: np.ndarray) -> bool:
    """``d`` reaches its extreme (the one away from where it starts) more than
    ``AFTER_REVERSAL`` samples before the stretch ends."""
    if not float(d.max() - d.min()) > 0:
        return True                                      # both flat: clipped together
    i = int(np.argmax(d)) if abs(d.max() - d[0]) >= abs(d.min() - d[0]) else int(np.argmin(d))
    return d.size - 1 - i > AFTER_REVERSAL


def is_clipped(x: np.ndarray, reference: np.ndarray | None = None) -> bool:
    """More than ``MIN_FRACTION`` of ``x`` sits in flat tops (see :func:`flat_top_fraction`)."""
    frac, _ = flat_top_fraction(x, reference)
    return frac > MIN_FRACTION


def refuse_clipped(x: np.ndarray, name: str, reference: np.ndarray | None = None,
                   what: str = "") -> None:
    """Raise :class:`InputError` naming ``name`` if ``x`` is clipped (:func:`is_clipped`).

    >>> refuse_clipped(np.clip(np.sin(np.arange(4000) / 20.0), -0.5, 0.5), "force")
    Traceback (most recent call last):
    ...
    labjoint.errors.InputError: 'force': is clipped: it sits at 0.5 in flat tops over 66.7 % of the samples (its input range was exceeded); its loop, energy loss and stiffness would be wrong: record it again with a larger input range
    """
    frac, level = flat_top_fraction(x, reference)
    if frac > MIN_FRACTION:
        raise InputError(f"is clipped: it sits at {level:.6g} in flat tops over "
                         f"{100 * frac:.1f} % of the samples (its input range was exceeded); "
                         f"{what or 'its loop, energy loss and stiffness'} would be wrong: "
                         "record it again with a larger input range", field=name)
