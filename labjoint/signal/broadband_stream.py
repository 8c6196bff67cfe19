"""FRFs of a record too long to hold: read in blocks, Welch sums accumulated block by block.

``read(start, stop)`` returns ``(drive, responses)`` for samples start..stop (the drive
(m,), the responses (S, m)); ``read_drive(start, stop)`` the drive alone. Three passes
at most, each holding one block:

1. the excitation, from probes of the drive (:func:`labjoint.signal.excitation.detect_streamed`);
2. the drive's envelope, from window sums block by block (:func:`broadband.window_sums`):
   the active part, and whether the drive comes in bursts;
3. the Welch sums over the active part (:class:`labjoint.signal.spectra.Welch`), the
   segment length and overlap as :func:`broadband.segment_length` chooses; the segments
   are transformed in single precision (``dtype``; the sums are kept in double: a
   record this long averages hundreds of segments, whose rounding at 1e-7 is far below
   their random error), which halves the time of the transforms.

A record that is not a steady random drive (a multisine, bursts, an impact, a sweep)
is read whole and handed to :func:`broadband.estimate`: those methods need every block
at once, and such records are short. The result is the one :func:`broadband.estimate`
gives for the same record in memory (both remove each segment's mean before its window)
to single precision.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from labjoint.errors import InputError
from labjoint.signal import broadband
from labjoint.signal.excitation import detect_streamed
from labjoint.signal.spectra import Welch

#: samples read at once (per channel)
BLOCK = 1 << 20


def estimate_streamed(read: Callable[[int, int], tuple[np.ndarray, np.ndarray]],
                      read_drive: Callable[[int, int], np.ndarray], n: int, fs: float,
                      responses: int, *, estimator: str = "H1", nperseg: int | None = None,
                      overlap: float | None = None, window: str = "hann", method: str = "auto",
                      burst: str = "block", dtype: Any = np.float32) -> broadband.BroadbandFrf:
    """FRFs of a record of ``n`` samples read through ``read`` (module docstring)."""
    if estimator not in broadband.ESTIMATORS:
        raise InputError(f"must be one of {broadband.ESTIMATORS}", field="estimator")
    broadband.check_nperseg(nperseg, n)
    broadband.check_burst(burst)
    exc = detect_streamed(read_drive, n, fs)
    broadband.refuse_narrowband(exc)
    if method not in ("auto", "welch"):
        f, y = read(0, n)
        return broadband.estimate(f, y, fs, estimator=estimator, excitation=exc, nperseg=nperseg,
                                  overlap=overlap, window=window, method=method, burst=burst)
    win = max(8, int(round(0.05 * fs)))
    step = max(win, BLOCK // win * win)
    sums = [broadband.window_sums(read_drive(a, min(n, a + step)), fs) for a in range(0, n, step)]
    s1 = np.concatenate([s[0] for s in sums])
    s2 = np.concatenate([s[1] for s in sums])
    rms = broadband.envelope(s1, s2, win)
    steady = exc.kind == "random" and not broadband.bursts_from(rms, win, n)
    if method == "auto" and not steady:
        f, y = read(0, n)
        return broadband.estimate(f, y, fs, estimator=estimator, excitation=exc, nperseg=nperseg,
                                  overlap=overlap, window=window, burst=burst)
    a0, a1 = broadband.active_from(rms, win, n)
    L, ov = broadband.segment_length(a1 - a0, fs)
    broadband.check_nperseg(nperseg, a1 - a0, "the active drive's length")
    L = int(nperseg or L)
    ov = ov if overlap is None else float(overlap)
    if a1 - a0 < L:
        raise InputError(f"the active drive holds {a1 - a0} samples, fewer than one segment of {L}",
                         field="drive")
    k0, k1 = a0 // win, max(a0 // win + 1, -(-a1 // win))
    mean = s1[k0:k1].sum() / ((k1 - k0) * win)
    rms_drive = float(np.sqrt(max(s2[k0:k1].sum() / ((k1 - k0) * win) - mean ** 2, 0.0)))
    w = Welch(L, fs, responses, window=window, overlap=ov, dtype=dtype)
    for a in range(a0, a1, BLOCK):
        w.feed(*read(a, min(a1, a + BLOCK)))      # each segment's mean removed (detrend)
    e = w.estimates()
    return broadband.result(w.freq_hz, e, estimator, rms_drive, (a0 / fs, a1 / fs),
                             f"Welch {estimator} over the active drive ({a0 / fs:.4g}-{a1 / fs:.4g} s), "
                             f"{window} segments of {L} samples, overlap {ov:g}, {w.count} segments, "
                             f"read in blocks of {BLOCK} samples")
