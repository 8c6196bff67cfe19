"""FRFs of a burst excitation (a random or impact drive that rests after each burst):
the bursts found in the drive's envelope, then one of two estimators (``burst=``):

- ``"block"`` (the default): one unwindowed block per burst, from its start to the next
  burst's (the last to the record's end), the free decay included, raw Y/U averaged over
  the bursts: the textbook burst-random H1 (what Simcenter Testlab computes), for a lab
  that compares with its analyser's processing.
- ``"driven"``: each burst over its driven part only, through the local rational method
  (:mod:`labjoint.signal.lrm`: the transients at the cut removed, exact for a linear
  system): the FRF at the burst's own amplitude, for level-dependent FRFs of a nonlinear
  structure (the free decay, where a joint rings at lower amplitude, left out). A drive
  shorter than a quarter of its block (an impact) is answered through its blocks.
"""

from __future__ import annotations

import numpy as np

from labjoint.errors import InputError
from labjoint.signal.broadband_base import (ACTIVE_FRACTION, ESTIMATORS, BroadbandFrf, blocks,
                                            envelope, result, window_sums)
from labjoint.signal.lrm import local_rational

#: the burst estimators (module docstring); "block" is the default
BURST_MODES = ("block", "driven")


def check_burst(mode: object) -> str:
    """``mode`` if it names a burst estimator, else InputError naming ``burst``."""
    if mode not in BURST_MODES:
        raise InputError(f"must be one of {', '.join(BURST_MODES)} (block: one unwindowed block per "
                         f"burst, its free decay included; driven: the driven part through the local "
                         f"rational method), got {mode!r}", field="burst")
    return str(mode)


def bursts(drive: np.ndarray, fs: float) -> list[tuple[int, int]]:
    """:func:`bursts_from` of a drive held in memory."""
    s1, s2, win = window_sums(drive, fs)
    return bursts_from(envelope(s1, s2, win), win, drive.size)


def bursts_from(rms: np.ndarray, win: int, n: int) -> list[tuple[int, int]]:
    """(start, end of drive) of each burst: active stretches (as :func:`active_from`) with
    silence after each of at least a tenth of its block; [] when the drive never rests so."""
    k = rms.size
    if k < 8 or not np.any(rms > 0):
        return []
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
    starts = [a for a, _ in runs] + [n // win]
    out = []
    for (a, b), nxt in zip(runs, starts[1:]):
        if (nxt - b) < 0.1 * (nxt - a):
            return []
        out.append((a * win, b * win))
    return out


#: a burst is taken over its driven part when that holds at least this share of its block
#: and this many samples; shorter drives (an impact) are answered through their blocks
DRIVEN_SHARE, MIN_DRIVEN_LINES = 0.25, 256


def burst_blocks(f: np.ndarray, y: np.ndarray, fs: float, estimator: str,
                 found: list[tuple[int, int]], label: str = "burst") -> BroadbandFrf:
    """One block per burst from its start to the next burst's (the last to the record's
    end), no window: the free decay is the burst's own response, not a driven stretch; the
    blocks (cut to the shortest) are averaged (the default, ``burst="block"``; an impact's
    blocks under ``burst="driven"``, ``label`` "impulse")."""
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
    return blocks(F, Y, fs, len(found), estimator, (a0 / fs, found[-1][1] / fs), rms,
                   f"{estimator} over {len(found)} {label} block(s) of {L} samples ({L / fs:.4g} s: "
                   f"{active / fs:.4g} s of drive, then the free decay, to {left:.1%} of the peak "
                   "response at the block's end), no window, burst="
                   + ("block" if label == "burst" else "driven (an impact: its whole blocks)")
                   + ("; std from the scatter between neighbouring lines" if len(found) == 1 else ""))


def burst(f: np.ndarray, y: np.ndarray, fs: float, estimator: str = "H1",
          found: list[tuple[int, int]] | None = None, mode: str = "block") -> BroadbandFrf:
    """Burst excitation through the estimator ``mode`` names (module docstring)."""
    mode = check_burst(mode)
    found = found or bursts(f, fs)
    if not found:
        raise InputError("no burst found: the drive does not rest after its active part", field="drive")
    if mode == "block":
        return burst_blocks(f, y, fs, estimator, found)
    return driven(f, y, fs, estimator, found)


def driven(f: np.ndarray, y: np.ndarray, fs: float, estimator: str,
           found: list[tuple[int, int]]) -> BroadbandFrf:
    """The driven part of each burst, unwindowed, through the local rational method
    (:mod:`labjoint.signal.lrm`: the transients at the cut removed), the bursts (cut to the
    shortest driven part) averaged. The free decay after the drive is left out: a
    nonlinear joint rings there at lower amplitude, at another frequency and damping,
    which would be mixed into the burst level's FRF. An impact: its blocks."""
    L = min(b - a for a, b in found)
    L -= L % 2
    starts = [a for a, _ in found] + [f.size]
    if L < MIN_DRIVEN_LINES or L < DRIVEN_SHARE * min(b - a for a, b in zip(starts, starts[1:])):
        return burst_blocks(f, y, fs, estimator, found, "impulse")
    seg = lambda x, a: x[..., a:a + L] - np.mean(x[..., a:a + L], axis=-1, keepdims=True)  # noqa: E731
    F = np.array([np.fft.rfft(seg(f, a))[1:] for a, _ in found])            # DC left out
    Y = np.array([np.fft.rfft(seg(y, a), axis=1)[:, 1:] for a, _ in found])
    fits = [local_rational(Fb, Yb) for Fb, Yb in zip(F, Y)]
    nb = len(found)
    h = np.mean([hb for hb, _ in fits], axis=0)
    std = np.sqrt(np.sum([sb ** 2 for _, sb in fits], axis=0)) / nb
    if nb > 1:      # the spread between bursts where it says more than the fits' residuals
        spread = np.std([hb for hb, _ in fits], axis=0, ddof=1) / np.sqrt(2 * nb)
        std = np.maximum(std, spread)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(np.abs(h) > 0, std / np.abs(h), np.inf)
    e = {k: h for k in ESTIMATORS}
    e.update(coherence=np.nan_to_num(1.0 / (1.0 + 2.0 * nb * rel ** 2), nan=0.0), eps=rel,
             n_d=float(nb), gff=np.sum(np.abs(F) ** 2, axis=0))
    fr = np.fft.rfftfreq(L, 1 / fs)[1:]
    rms = float(np.sqrt(np.mean([np.mean(f[a:b] ** 2) for a, b in found])))
    return result(fr, e, estimator, rms, (found[0][0] / fs, found[-1][1] / fs),
                   f"{estimator} over the driven part of {nb} burst(s) ({L} samples, {L / fs:.4g} s "
                   "each, the free decay after it left out), no window, transients removed by "
                   "the local rational method (burst=driven; H1, H2 and Hv coincide; std from its residuals"
                   + (" and the spread between bursts)" if nb > 1 else ")"), std)
