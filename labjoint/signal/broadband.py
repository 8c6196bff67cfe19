"""FRFs of a broadband record: one drive (force or voltage), any number of responses.

The method follows the excitation found in the drive (:mod:`labjoint.signal.excitation`):

- **periodic** (a multisine with a whole number of samples per period and at least three
  periods): the first period is dropped (start-up transient), the DFT of every further
  period is taken with no window, and at the excited lines H = mean_p Y_p / mean_p F_p
  (exact for a linear system: no leakage). The standard deviations come from the
  period-to-period spread (Pintelon & Schoukens, *System Identification*, 2nd ed.,
  Sec. 2.4: var(Y_mean) = var_p(Y_p) / P; the FRF's by first-order propagation through
  the ratio), coherence from the same sums.
- **burst** (a random or impact drive that rests after each burst, for at least a tenth
  of the block; the bursts found from the drive's moving RMS, above 5 % of the median of
  its driven part; :mod:`labjoint.signal.burst`), by ``burst=``:

  - ``"block"`` (default): one block per burst, from its start to the next burst's (the
    last to the record's end), no window, the blocks averaged: the textbook burst-random
    H1, as Simcenter Testlab computes it. The free decay after a burst is the response to
    that burst: it belongs to its block unwindowed, never averaged as a driven stretch.
    The method names how far the response has decayed at the block's end (what is left
    leaks). Several bursts give H1, H2, Hv, coherence and the Bendat & Piersol errors
    with n_d = bursts; a single burst one average, its std from the scatter of H between
    neighbouring lines (second differences: var = 1.5 sigma^2 per component for
    independent errors, a running median over 17 lines) and the coherence that std
    implies.
  - ``"driven"``: each burst over its driven part only, unwindowed, through the local
    rational method (:mod:`labjoint.signal.lrm`: the transient left by cutting the
    response while the modes ring is fitted and removed, exact for a linear system), the
    bursts averaged: the FRF at the burst's own amplitude. The free decay, where a
    nonlinear joint rings at a lower amplitude (another frequency and damping), is left
    out; the std comes from the local fits' residuals (and the spread between bursts).
    For level-dependent FRFs of a nonlinear structure; about 10x the CPU of "block". A
    drive shorter than a quarter of its block (an impact) is answered through its blocks.
- **random** (steady): Welch's spectra (:mod:`labjoint.signal.spectra`) over the active
  part of the drive only (its moving RMS above 5 % of the median of its driven part).
  Segment: the largest power of two that gives at least three segments at half overlap
  (capped at 2^16 samples), Hann window; a record of fewer than 16 segments overlaps
  them by 3/4, one of 128 or more segments end to end does not overlap them. H1, H2,
  Hv, coherence and the Bendat & Piersol random errors (Eq. 9.90).
- **swept sine** (or ``method="block"``): the whole record as one block, no window (the
  record is assumed to start at rest and the response to decay within it), one average,
  std from the scatter as for a single burst.

The drive and the estimator are explicit: :class:`BroadbandFrf` carries the response
quantities and units, and the drive quantity ("force", N, or "voltage", V).

>>> fs, n = 1024.0, 1 << 15
>>> rng = np.random.default_rng(1)
>>> f = rng.normal(size=n)
>>> r = estimate(f, np.vstack([f, 3 * f]), fs)
>>> r.method.split(",")[0], bool(np.allclose(r.h[1, 1:], 3.0))
('Welch H1 over the active drive (0-32 s)', True)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.signal import validate
from labjoint.signal.broadband_base import (ACTIVE_FRACTION, ESTIMATORS, BroadbandFrf,  # noqa: F401
                                            active_from, active_part, blocks, drive_band, envelope,
                                            result, scatter_std, window_sums)
from labjoint.signal.burst import (BURST_MODES, burst, burst_blocks, bursts, bursts_from,  # noqa: F401
                                   check_burst, driven)
from labjoint.signal.burst import burst as burst_estimate
from labjoint.signal.excitation import Excitation, detect_excitation
from labjoint.signal.spectra import Welch, estimates_from

MAX_SEGMENT = 1 << 16
#: a record holding this many segments end to end is averaged without overlap (the
#: random error is then below ~3 % at coherence 0.9; overlap would double the work)
LONG_RECORD_SEGMENTS = 128


def segment_length(n: int, fs: float) -> tuple[int, float]:
    """(nperseg, overlap) chosen from the samples available (module docstring)."""
    L = 1 << int(np.floor(np.log2(max(n / 2, 8))))
    L = min(L, MAX_SEGMENT)
    if n // L >= LONG_RECORD_SEGMENTS:
        return L, 0.0
    overlap = 0.5 if (n - L) // (L // 2) + 1 >= 16 else 0.75
    return L, overlap


def estimate(drive: Any, responses: Any, fs: float, *, estimator: str = "H1",
             excitation: Excitation | None = None, nperseg: int | None = None,
             overlap: float | None = None, window: str = "hann",
             method: str = "auto", burst: str = "block") -> BroadbandFrf:
    """FRFs of ``responses`` (S, n) over ``drive`` (n,) sampled at ``fs`` (module doc).
    ``method``: "auto" (from the excitation), "welch", "periodic", "burst" or "block";
    ``burst``: the estimator of a burst record, "block" or "driven"."""
    fs = validate.sample_rate(fs)
    f = validate.signal(drive, "drive", min_samples=16)
    y = np.atleast_2d(validate.signal(responses, "responses", min_samples=16, ndim=(1, 2)))
    validate.same_length(f, y, "drive", "responses")
    if estimator not in ESTIMATORS:
        raise InputError(f"must be one of {ESTIMATORS}", field="estimator")
    check_nperseg(nperseg, f.size)
    mode = check_burst(burst)
    if method == "auto":
        exc = excitation or detect_excitation(f, fs)
        per = exc.period_s * fs if exc.kind == "multisine" and exc.period_s else 0.0
        n = int(round(per))
        if n and abs(per - n) < 1e-6 * n and f.size // n >= 3:
            return periodic(f, y, fs, n, estimator)
        refuse_narrowband(exc)
        found = bursts(f, fs) if exc.kind in ("random", "transient") else []
        if found:
            return burst_estimate(f, y, fs, estimator, found, mode)
        method = "block" if exc.kind in ("transient", "swept_sine") else "welch"
    if method == "periodic":
        exc = excitation or detect_excitation(f, fs)
        if not exc.period_s:
            raise InputError("the drive is not periodic", field="drive")
        return periodic(f, y, fs, int(round(exc.period_s * fs)), estimator)
    if method == "block":
        return block(f, y, fs, estimator)
    if method == "burst":
        return burst_estimate(f, y, fs, estimator, None, mode)
    if method != "welch":
        raise InputError("must be auto, welch, periodic, burst or block", field="method")
    a0, a1 = active_part(f, fs)
    L, ov = segment_length(a1 - a0, fs)
    L = int(nperseg or L)
    ov = ov if overlap is None else float(overlap)
    check_nperseg(nperseg, a1 - a0, "the active drive's length")
    if a1 - a0 < L:
        raise InputError(f"the active drive holds {a1 - a0} samples, fewer than one segment of {L}",
                         field="drive")
    w = Welch(L, fs, y.shape[0], window=window, overlap=ov)
    mu = np.mean(f[a0:a1]), np.mean(y[:, a0:a1], axis=1, keepdims=True)
    w.feed(f[a0:a1] - mu[0], y[:, a0:a1] - mu[1])
    e = w.estimates()
    return result(w.freq_hz, e, estimator, float(np.std(f[a0:a1])), (a0 / fs, a1 / fs),
                   f"Welch {estimator} over the active drive ({a0 / fs:.4g}-{a1 / fs:.4g} s), "
                   f"{window} segments of {L} samples, overlap {ov:g}, {w.count} segments")


MIN_SEGMENT = 16


def check_nperseg(nperseg: Any, n: int, what: str = "the record's length") -> None:
    """A given segment length is a whole number of samples from 16 to ``n``, or InputError
    naming ``nperseg`` and the range (a segment longer than the data is never silently
    replaced by another method's choice)."""
    if nperseg is None:
        return
    ok = isinstance(nperseg, (int, np.integer)) and not isinstance(nperseg, bool)
    if not ok or not MIN_SEGMENT <= int(nperseg) <= n:
        raise InputError(f"must be a whole number of samples from {MIN_SEGMENT} to {n} "
                         f"({what}), got {nperseg!r}", field="nperseg")


def refuse_narrowband(exc: Excitation) -> None:
    """A silent drive or a steady sine has no broadband FRF: say what handles it."""
    if exc.kind == "none":
        raise InputError("the drive is silent: no FRF can be estimated", field="drive")
    if exc.kind == "sine":
        raise InputError(f"the drive is {exc.describe()}, not broadband: an FRF set of step sines is "
                         "`labjoint structure measured`, its harmonics `labjoint distortion`",
                         field="drive")

def periodic(f: np.ndarray, y: np.ndarray, fs: float, n: int, estimator: str = "H1") -> BroadbandFrf:
    """Whole periods of ``n`` samples after the first: exact at the excited lines."""
    P = f.size // n - 1
    if P < 2:
        raise InputError(f"needs at least 3 whole periods of {n} samples, got {f.size // n}", field="drive")
    F = np.fft.rfft(f[n:(P + 1) * n].reshape(P, n), axis=1) * (2.0 / n)
    Y = np.fft.rfft(y[:, n:(P + 1) * n].reshape(y.shape[0], P, n), axis=2) * (2.0 / n)
    pf = np.mean(np.abs(F) ** 2, axis=0)
    lines = np.flatnonzero(pf > 1e-6 * pf.max())
    lines = lines[lines > 0]
    F, Y = F[:, lines], Y[:, :, lines]
    gff, gyy = np.mean(np.abs(F) ** 2, axis=0), np.mean(np.abs(Y) ** 2, axis=1)
    gfy = np.mean(np.conj(F)[None] * Y, axis=1)
    e = estimates_from(gff, gyy, gfy, float(P))
    Fm, Ym = F.mean(axis=0), Y.mean(axis=1)
    h = Ym / Fm
    e["H1"] = h   # the mean-period ratio (P&S): exact without noise, as H1 is
    vf = np.var(F, axis=0, ddof=1) / P
    vy = np.var(Y, axis=1, ddof=1) / P
    cov = np.mean((Y - Ym[:, None]) * np.conj(F - Fm)[None], axis=1) * P / (P - 1) / P
    var_h = (vy + np.abs(h) ** 2 * vf - 2 * np.real(np.conj(h) * cov)) / np.abs(Fm) ** 2
    std = np.sqrt(np.maximum(var_h, 0) / 2)   # per component (re, im)
    return result(lines * fs / n, e, estimator, float(np.std(f[n:])), (0.0, f.size / fs),
                   f"{estimator} over {P} steady periods of {n} samples at the {lines.size} excited "
                   "lines, no window", std)

def block(f: np.ndarray, y: np.ndarray, fs: float, estimator: str = "H1") -> BroadbandFrf:
    """The whole record as one block, no window (an impact, a sweep)."""
    n = f.size - f.size % 2
    F = np.fft.rfft(f[:n] - f[: max(1, n // 50)].mean())[None]
    Y = np.fft.rfft(y[:, :n] - y[:, : max(1, n // 50)].mean(axis=1, keepdims=True), axis=1)[None]
    return blocks(F, Y, fs, 1, estimator, (0.0, n / fs), float(np.std(f[:n])),
                   f"{estimator} of the whole record as one block ({n} samples), no window, "
                   "one average (std from the scatter between neighbouring lines)")
