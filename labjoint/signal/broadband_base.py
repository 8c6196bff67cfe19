"""The shared parts of the broadband FRF estimators (:mod:`labjoint.signal.broadband`):
the result, the drive's envelope and active part, the estimates of unwindowed blocks.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.signal.spectra import estimates_from

ESTIMATORS = ("H1", "H2", "Hv")
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


def window_sums(drive: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray, int]:
    """(sum of x, sum of x^2) over consecutive windows of 0.05 s (at least 8 samples),
    and the window length: what the drive's envelope is made of (a record read in
    pieces of whole windows gives the same sums piece by piece)."""
    win = max(8, int(round(0.05 * fs)))
    k = drive.size // win
    x = np.asarray(drive[:k * win], float).reshape(k, win)
    return x.sum(axis=1), np.einsum("kw,kw->k", x, x), win


def envelope(s1: np.ndarray, s2: np.ndarray, win: int) -> np.ndarray:
    """The moving RMS about the record's mean from :func:`window_sums`."""
    m = s1.sum() / max(1, s1.size * win)
    return np.sqrt(np.maximum(s2 / win - 2 * m * s1 / win + m * m, 0.0))


def active_from(rms: np.ndarray, win: int, n: int) -> tuple[int, int]:
    """First and last+1 sample where the drive acts (module docstring); the whole record
    when the drive never falls silent."""
    k = rms.size
    if k < 4 or not np.any(rms > 0):
        return 0, n
    driven = rms > 0.1 * rms.max()
    on = rms > ACTIVE_FRACTION * np.median(rms[driven])
    idx = np.flatnonzero(on)
    a0, a1 = int(idx[0]) * win, (int(idx[-1]) + 1) * win
    return a0, (n if a1 >= k * win else a1)


def active_part(drive: np.ndarray, fs: float) -> tuple[int, int]:
    """:func:`active_from` of a drive held in memory."""
    s1, s2, win = window_sums(drive, fs)
    return active_from(envelope(s1, s2, win), win, drive.size)


def result(fr: np.ndarray, e: dict[str, np.ndarray], estimator: str, rms: float,
           active: tuple[float, float], method: str, std: np.ndarray | None = None) -> BroadbandFrf:
    keep = (fr > 0) & np.all(np.isfinite(e["H1"]), axis=0) & np.all(np.isfinite(e[estimator]), axis=0)
    h = e[estimator][:, keep]
    if std is None:
        std = np.abs(h) * np.minimum(e["eps"][:, keep], 1e6)
    else:
        std = std[:, keep]
    return BroadbandFrf(fr[keep], h, std, e["coherence"][:, keep],
                        {k: e[k][:, keep] for k in ESTIMATORS}, float(e["n_d"]), method, rms, active,
                        {"drive_power": e["gff"][keep]})


def drive_band(r: BroadbandFrf) -> list[float]:
    """First and last line where the drive's power (smoothed over ~1/256 of the lines)
    is above 1 % of its largest: the band the FRF is measured in."""
    p = np.asarray(r.extra.get("drive_power", np.ones(r.freq_hz.size)), float)
    if p.size == 0:
        return [0.0, 0.0]
    m = max(1, p.size // 256)
    ps = np.convolve(p, np.ones(m) / m, mode="same") if m > 1 else p
    ok = np.flatnonzero(ps > 0.01 * ps.max())
    return [float(r.freq_hz[ok[0]]), float(r.freq_hz[ok[-1]])]


def scatter_std(h: np.ndarray) -> np.ndarray:
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


def blocks(F: np.ndarray, Y: np.ndarray, fs: float, nb: int, estimator: str,
           active: tuple[float, float], rms: float, method: str) -> BroadbandFrf:
    """Estimates from ``nb`` unwindowed blocks' spectra F (nb, f), Y (nb, S, f)."""
    gff = np.sum(np.abs(F) ** 2, axis=0)
    gyy = np.sum(np.abs(Y) ** 2, axis=0)
    gfy = np.sum(np.conj(F)[:, None] * Y, axis=0)
    e = estimates_from(gff, gyy, gfy, float(nb))
    std = None
    if nb == 1:   # one average: coherence is 1 by construction; the scatter tells the noise
        std = scatter_std(e[estimator])
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(np.abs(e[estimator]) > 0, std / np.abs(e[estimator]), np.inf)
        e["coherence"] = np.nan_to_num(1.0 / (1.0 + 2.0 * rel ** 2), nan=0.0)
    fr = np.fft.rfftfreq(2 * (F.shape[-1] - 1), 1 / fs)
    return result(fr, e, estimator, rms, active, method, std)
