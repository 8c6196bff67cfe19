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
  its driven part): one block per burst, from its start to the next burst's (the last to
  the record's end), no window, the blocks averaged. The free decay after a burst is the
  response to that burst: it belongs to its block unwindowed, never averaged as a driven
  stretch. The method names how far the response has decayed at the block's end (what
  is left leaks). Several bursts give H1, H2, Hv, coherence and the Bendat & Piersol
  errors with n_d = bursts; a single burst one average, its std from the scatter of H
  between neighbouring lines (second differences: var = 1.5 sigma^2 per component for
  independent errors, a running median over 17 lines) and the coherence that std implies.
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

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.signal import validate
from labjoint.signal.excitation import Excitation, detect_excitation
from labjoint.signal.spectra import Welch, estimates_from

ESTIMATORS = ("H1", "H2", "Hv")
MAX_SEGMENT = 1 << 16
#: a record holding this many segments end to end is averaged without overlap (the
#: random error is then below ~3 % at coherence 0.9; overlap would double the work)
LONG_RECORD_SEGMENTS = 128
#: the active part: drive's moving RMS above this fraction of the driven part's median
ACTIVE_FRACTION = 0.05


@dataclass(frozen=True)
class BroadbandFrf:
    """FRFs (S responses x n lines) with their estimators, coherence and std."""

    freq_hz: np.ndarray           # (n,)
    h: np.ndarray                 # (S, n) the chosen estimator
    std: np.ndarray               # (S, n) std of each component (re, im) of h
    coherence: np.ndarray         # (S, n)
    alternatives: dict[str, np.ndarray]   # every estimator, (S, n) each
    averages: float               # independent averages n_d
    method: str
    drive_rms: float              # RMS of the drive over the part used (its units)
    active_s: tuple[float, float]
    extra: dict[str, Any] = field(default_factory=dict)


def active_part(drive: np.ndarray, fs: float) -> tuple[int, int]:
    """First and last+1 sample where the drive acts (module docstring); the whole record
    when the drive never falls silent."""
    x = drive - np.median(drive)
    win = max(8, int(round(0.05 * fs)))
    k = x.size // win
    if k < 4:
        return 0, x.size
    rms = np.sqrt(np.mean(x[:k * win].reshape(k, win) ** 2, axis=1))
    driven = rms > 0.1 * rms.max()
    on = rms > ACTIVE_FRACTION * np.median(rms[driven])
    idx = np.flatnonzero(on)
    a0, a1 = int(idx[0]) * win, (int(idx[-1]) + 1) * win
    return a0, (x.size if a1 >= k * win else a1)


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
             method: str = "auto") -> BroadbandFrf:
    """FRFs of ``responses`` (S, n) over ``drive`` (n,) sampled at ``fs`` (module doc).
    ``method``: "auto" (from the excitation), "welch", "periodic", "burst" or "block"."""
    fs = validate.sample_rate(fs)
    f = validate.signal(drive, "drive", min_samples=16)
    y = np.atleast_2d(validate.signal(responses, "responses", min_samples=16, ndim=(1, 2)))
    validate.same_length(f, y, "drive", "responses")
    if estimator not in ESTIMATORS:
        raise InputError(f"must be one of {ESTIMATORS}", field="estimator")
    if method == "auto":
        exc = excitation or detect_excitation(f, fs)
        per = exc.period_s * fs if exc.kind == "multisine" and exc.period_s else 0.0
        n = int(round(per))
        if n and abs(per - n) < 1e-6 * n and f.size // n >= 3:
            return periodic(f, y, fs, n, estimator)
        if exc.kind == "none":
            raise InputError("the drive is silent: no FRF can be estimated", field="drive")
        found = bursts(f, fs) if exc.kind in ("random", "transient") else []
        if found:
            return burst(f, y, fs, estimator, found)
        method = "block" if exc.kind in ("transient", "swept_sine") else "welch"
    if method == "periodic":
        exc = excitation or detect_excitation(f, fs)
        if not exc.period_s:
            raise InputError("the drive is not periodic", field="drive")
        return periodic(f, y, fs, int(round(exc.period_s * fs)), estimator)
    if method == "block":
        return block(f, y, fs, estimator)
    if method == "burst":
        return burst(f, y, fs, estimator)
    if method != "welch":
        raise InputError("must be auto, welch, periodic, burst or block", field="method")
    a0, a1 = active_part(f, fs)
    L, ov = segment_length(a1 - a0, fs)
    L = int(nperseg or L)
    ov = ov if overlap is None else float(overlap)
    if a1 - a0 < L:
        raise InputError(f"the active drive holds {a1 - a0} samples, fewer than one segment of {L}",
                         field="drive")
    w = Welch(L, fs, y.shape[0], window=window, overlap=ov)
    mu = np.mean(f[a0:a1]), np.mean(y[:, a0:a1], axis=1, keepdims=True)
    w.feed(f[a0:a1] - mu[0], y[:, a0:a1] - mu[1])
    e = w.estimates()
    return _result(w.freq_hz, e, estimator, float(np.std(f[a0:a1])), (a0 / fs, a1 / fs),
                   f"Welch {estimator} over the active drive ({a0 / fs:.4g}-{a1 / fs:.4g} s), "
                   f"{window} segments of {L} samples, overlap {ov:g}, {w.count} segments")


def _result(fr: np.ndarray, e: dict[str, np.ndarray], estimator: str, rms: float,
            active: tuple[float, float], method: str, std: np.ndarray | None = None) -> BroadbandFrf:
    keep = (fr > 0) & np.all(np.isfinite(e["H1"]), axis=0) & np.all(np.isfinite(e[estimator]), axis=0)
    h = e[estimator][:, keep]
    if std is None:
        std = np.abs(h) * np.minimum(e["eps"][:, keep], 1e6)
    else:
        std = std[:, keep]
    return BroadbandFrf(fr[keep], h, std, e["coherence"][:, keep],
                        {k: e[k][:, keep] for k in ESTIMATORS}, float(e["n_d"]), method, rms, active)


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
    return _result(lines * fs / n, e, estimator, float(np.std(f[n:])), (0.0, f.size / fs),
                   f"{estimator} over {P} steady periods of {n} samples at the {lines.size} excited "
                   "lines, no window", std)


def _scatter_std(h: np.ndarray) -> np.ndarray:
    """Per-component std of single-average FRFs from the scatter between neighbouring
    lines: second differences (var = 1.5 sigma^2 per component), running median of 17."""
    from scipy.ndimage import median_filter

    std = np.full(h.shape, np.inf)
    if h.shape[1] >= 20:
        d = h[:, 1:-1] - 0.5 * (h[:, :-2] + h[:, 2:])
        d2 = np.abs(np.nan_to_num(d, nan=0.0)) ** 2
        std[:, 1:-1] = np.sqrt(median_filter(d2, size=(1, 17), mode="nearest") / np.log(2) / 3.0)
        std[:, 0], std[:, -1] = std[:, 1], std[:, -2]
    return std


def _blocks(F: np.ndarray, Y: np.ndarray, fs: float, nb: int, estimator: str,
            active: tuple[float, float], rms: float, method: str) -> BroadbandFrf:
    """Estimates from ``nb`` unwindowed blocks' spectra F (nb, f), Y (nb, S, f)."""
    gff = np.sum(np.abs(F) ** 2, axis=0)
    gyy = np.sum(np.abs(Y) ** 2, axis=0)
    gfy = np.sum(np.conj(F)[:, None] * Y, axis=0)
    e = estimates_from(gff, gyy, gfy, float(nb))
    std = None
    if nb == 1:   # one average: coherence is 1 by construction; the scatter tells the noise
        std = _scatter_std(e[estimator])
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(np.abs(e[estimator]) > 0, std / np.abs(e[estimator]), np.inf)
        e["coherence"] = np.nan_to_num(1.0 / (1.0 + 2.0 * rel ** 2), nan=0.0)
    fr = np.fft.rfftfreq(2 * (F.shape[-1] - 1), 1 / fs)
    return _result(fr, e, estimator, rms, active, method, std)


def block(f: np.ndarray, y: np.ndarray, fs: float, estimator: str = "H1") -> BroadbandFrf:
    """The whole record as one block, no window (an impact, a sweep)."""
    n = f.size - f.size % 2
    F = np.fft.rfft(f[:n] - f[: max(1, n // 50)].mean())[None]
    Y = np.fft.rfft(y[:, :n] - y[:, : max(1, n // 50)].mean(axis=1, keepdims=True), axis=1)[None]
    return _blocks(F, Y, fs, 1, estimator, (0.0, n / fs), float(np.std(f[:n])),
                   f"{estimator} of the whole record as one block ({n} samples), no window, "
                   "one average (std from the scatter between neighbouring lines)")


def bursts(drive: np.ndarray, fs: float) -> list[tuple[int, int]]:
    """(start, end of drive) of each burst: active stretches (as :func:`active_part`) with
    silence after each of at least a tenth of its block; [] when the drive never rests so."""
    x = drive - np.median(drive)
    win = max(8, int(round(0.05 * fs)))
    k = x.size // win
    if k < 8:
        return []
    rms = np.sqrt(np.mean(x[:k * win].reshape(k, win) ** 2, axis=1))
    on = rms > ACTIVE_FRACTION * np.median(rms[rms > 0.1 * rms.max()])
    runs, i = [], 0
    while i < k:
        if on[i]:
            j = i
            while j < k and on[j]:
                j += 1
            if runs and i - runs[-1][1] < 4:      # a dip of less than 0.2 s: the same burst
                runs[-1] = (runs[-1][0], j)
            else:
                runs.append((i, j))
            i = j
        else:
            i += 1
    starts = [a for a, _ in runs] + [x.size // win]
    out = []
    for (a, b), nxt in zip(runs, starts[1:]):
        if (nxt - b) < 0.1 * (nxt - a):
            return []
        out.append((a * win, b * win))
    return out


def burst(f: np.ndarray, y: np.ndarray, fs: float, estimator: str = "H1",
          found: list[tuple[int, int]] | None = None) -> BroadbandFrf:
    """Burst excitation: one block per burst from its start to the next burst (the last to
    the record's end), no window: the free decay is the burst's own response, not a
    driven stretch; the blocks (cut to the shortest) are averaged."""
    found = found or bursts(f, fs)
    if not found:
        raise InputError("no burst found: the drive does not rest after its active part", field="drive")
    starts = [a for a, _ in found] + [f.size]
    L = min(b - a for a, b in zip(starts, starts[1:]))
    L -= L % 2
    if L < 16:
        raise InputError(f"a burst block holds {L} samples, too few", field="drive")
    seg = lambda x, a: x[..., a:a + L] - np.mean(x[..., a:a + L], axis=-1, keepdims=True)  # noqa: E731
    F = np.array([np.fft.rfft(seg(f, a)) for a, _ in found])
    Y = np.array([np.fft.rfft(seg(y, a), axis=1) for a, _ in found])
    a0 = found[0][0]
    tail = y[:, a0 + L - max(1, L // 20): a0 + L]
    peak = max(float(np.max(np.abs(y[:, a0:a0 + L]))), 1e-300)
    left = float(np.max(np.sqrt(np.mean(tail ** 2, axis=1)))) / peak
    active = float(np.mean([b - a for a, b in found]))
    rms = float(np.sqrt(np.mean([np.mean(f[a:b] ** 2) for a, b in found])))
    return _blocks(F, Y, fs, len(found), estimator, (a0 / fs, found[-1][1] / fs), rms,
                   f"{estimator} over {len(found)} burst block(s) of {L} samples ({L / fs:.4g} s: "
                   f"{active / fs:.4g} s of drive, then the free decay, to {left:.1%} of the peak "
                   "response at the block's end), no window"
                   + ("; std from the scatter between neighbouring lines" if len(found) == 1 else ""))
