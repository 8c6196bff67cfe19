"""Distortion of a record before any model: harmonics of a steady sine, and the odd and
even nonlinear distortion of a multisine with detection lines.

**Steady sine.** The drive's frequency f0 is measured (:func:`estimate_frequency`, phase
slope). The steady part starts after the drive's first tenth and after the responses
have settled (:func:`settled_start`: a lightly damped structure started from rest rings at
its natural frequency for several decay times, and at f0 = f_n / 2 that ringing sits on the
2nd harmonic); it is cut into ``blocks`` blocks of whole cycles (the nearest sample); in
each block every channel is fitted by least
squares with a constant and cos/sin at h f0, h = 1..2H+1 (below Nyquist; the harmonics
above H absorb what would leak from them), giving its phasors X_h. Per block
the ratio r_h = |X_h| / |X_1|; the reported ratio is their mean and its standard error
the spread between blocks over sqrt(blocks).

**Multisine with detection lines** (an odd or random-odd design: only odd lines, some of
them left out; Pintelon & Schoukens, *System Identification*, 2nd ed., Sec. 3.4-3.6 and
4.3). Over P whole periods after the first: the mean spectrum over periods and its noise
variance var_p / P per line. At the excited lines the best linear approximation (BLA)
G = mean Y / mean U with its noise std, and its total std with the stochastic nonlinear
contribution (the power at the neighbouring odd detection lines, interpolated: P&S
Sec. 3.6 and 4.3); at the non-excited odd lines the odd nonlinear
distortion, at the even lines the even one, each against the noise level on the same
lines. Per band (the excited range cut into ``bands`` equal bands): mean power of the odd
and of the even detection lines over the mean noise power, in dB. The summary names the
strongest: "nonlinear, even and odd, x dB above the noise near y Hz" (a kind counts when
it stands 6 dB above the noise).

>>> fs, f0 = 1000.0, 10.0
>>> t = np.arange(20_000) / fs
>>> u = np.sin(2 * np.pi * f0 * t)
>>> f, res = harmonics({"u": u, "y": u + 0.1 * u ** 2 - 0.2 * u ** 3}, fs, drive="u", orders=3)
>>> [round(r["ratio"], 4) for r in res["y"]]
[1.0, 0.0588, 0.0588]
"""

from __future__ import annotations

from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.signal import validate
from labjoint.signal.frequency import estimate_frequency

#: a kind of distortion counts when it stands this many dB above the noise
DETECT_DB = 6.0


def harmonics(channels: dict[str, Any], fs: float, *, drive: str, orders: int = 5,
              blocks: int = 8, frequency_hz: float | None = None
              ) -> tuple[float, dict[str, list[dict[str, Any]]]]:
    """(f0, {channel: [{"order", "ratio", "stderr", "amplitude"}], h = 2..orders})."""
    fs = validate.sample_rate(fs)
    if drive not in channels:
        raise InputError(f"no drive channel {drive!r}; channels: {list(channels)}", field="drive")
    if orders < 2:
        raise InputError(f"must be >= 2, got {orders}", field="orders")
    u = validate.signal(channels[drive], drive, min_samples=64)
    f0 = float(frequency_hz) if frequency_hz else estimate_frequency(u, fs)
    if not 0 < f0 * orders < fs / 2:
        raise InputError(f"harmonic {orders} of {f0:g} Hz is at or above Nyquist ({fs / 2:g} Hz)",
                         field="orders")
    per = fs / f0
    a0, a1 = steady_part(u, fs, f0)
    fit = max(orders, min(2 * orders + 1, int(np.floor(0.5 * fs / f0 * 0.999))))
    responses = {n: validate.signal(x, n, min_samples=u.size) for n, x in channels.items()
                 if n != drive}
    start = max(a0 + int(np.ceil((a1 - a0) / 10)),
                settled_start(responses, fs, f0, a0, a1, fit))
    cycles = int((a1 - start) / per)
    k = cycles // blocks
    if k < 2:
        raise InputError(f"{cycles} whole cycles of {f0:g} Hz after the start-up: too few for "
                         f"{blocks} blocks of two or more", field=drive)
    edges = [start + int(round(b * k * per)) for b in range(blocks + 1)]
    # harmonics above those reported are fitted too (up to 2H + 1, below Nyquist, `fit`):
    # a block is whole cycles only to the nearest sample, and a strong unfitted harmonic
    # would leak
    out: dict[str, list[dict[str, Any]]] = {}
    for name, x in channels.items():
        x = validate.signal(x, name, min_samples=u.size)
        ph = np.array([_phasors(x[a:b], fs, f0, fit, a)[:orders] for a, b in zip(edges, edges[1:])])
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.abs(ph[:, 1:]) / np.abs(ph[:, :1])
        out[name] = [{"order": h + 2, "ratio": float(np.mean(r[:, h])),
                      "stderr": float(np.std(r[:, h], ddof=1) / np.sqrt(blocks)),
                      "amplitude": float(np.mean(np.abs(ph[:, h + 1])))} for h in range(orders - 1)]
        out[name].insert(0, {"order": 1, "ratio": 1.0, "stderr": 0.0,
                             "amplitude": float(np.mean(np.abs(ph[:, 0])))})
    return f0, out


def steady_part(u: np.ndarray, fs: float, f0: float) -> tuple[int, int]:
    """The longest stretch where the drive's RMS over two-cycle windows stays within 10 %
    of the median of its driven windows (a sine stopped before the record ends, its
    ramps, left out)."""
    win = max(4, int(round(2 * fs / f0)))
    k = u.size // win
    if k < 3:
        return 0, u.size
    rms = np.sqrt(np.mean((u[:k * win] - np.mean(u)).reshape(k, win) ** 2, axis=1))
    level = np.median(rms[rms > 0.1 * rms.max()])
    ok = np.abs(rms / level - 1) <= 0.1
    best, run, b0 = (0, 0), 0, 0
    for i, v in enumerate(ok):
        run, b0 = (run + 1, b0) if v else (0, i + 1)
        if run > best[1] - best[0]:
            best = (b0, i + 1)
    return best[0] * win, best[1] * win


def settled_start(responses: dict[str, np.ndarray], fs: float, f0: float, a0: int, a1: int,
                  fit: int) -> int:
    """First sample of the driven part [a0, a1) from which every response's harmonics stay
    steady: the driven part is cut into short blocks of whole cycles (4 cycles, at least a
    quarter second); per block the phasors X_h, h = 1..fit; the reference is their median
    over the last half of the blocks; a block deviates by max_h |X_h - X_h,ref| / |X_1,ref|.
    Settled from the first block after which every deviation stays within three times the
    typical deviation of the last half (noise and slow drift) and 0.2 % of the fundamental
    at least. Never later than the middle of the driven part (a record whose response never
    settles still gives its second half)."""
    per = fs / f0
    m = max(4, int(np.ceil(0.25 * f0)))
    nb = int((a1 - a0) / (m * per))
    if nb < 8 or not responses:
        return a0
    edges = [a0 + int(round(b * m * per)) for b in range(nb + 1)]
    settled = 0
    for x in responses.values():
        ph = np.array([_phasors(x[a:b], fs, f0, fit, a) for a, b in zip(edges, edges[1:])])
        tail = ph[nb // 2:]
        ref = np.median(tail.real, axis=0) + 1j * np.median(tail.imag, axis=0)
        if not np.abs(ref[0]) > 0:
            continue
        d = np.max(np.abs(ph - ref), axis=1) / np.abs(ref[0])
        tol = max(3.0 * float(np.median(d[nb // 2:])), 2e-3)
        bad = np.nonzero(d > tol)[0]
        if bad.size:
            settled = max(settled, int(bad[-1]) + 1)
    return edges[min(settled, nb // 2)]


def _phasors(x: np.ndarray, fs: float, f0: float, orders: int, offset: int) -> np.ndarray:
    t = (offset + np.arange(x.size)) / fs
    w = 2 * np.pi * f0 * np.arange(1, orders + 1)[None, :] * t[:, None]
    A = np.hstack([np.ones((x.size, 1)), np.cos(w), np.sin(w)])
    c = np.linalg.lstsq(A, x, rcond=None)[0]
    return c[1:orders + 1] - 1j * c[orders + 1:]


def multisine(drive: Any, response: Any, fs: float, period_samples: int, *, bands: int = 6
              ) -> dict[str, Any]:
    """BLA and odd/even nonlinear distortion against the noise (module docstring)."""
    fs = validate.sample_rate(fs)
    u = validate.signal(drive, "drive", min_samples=16)
    y = validate.signal(response, "response", min_samples=16)
    validate.same_length(u, y, "drive", "response")
    n = int(period_samples)
    P = u.size // n - 1
    if P < 2:
        raise InputError(f"needs at least 3 whole periods of {n} samples, got {u.size // n}",
                         field="drive")
    U = np.fft.rfft(u[n:(P + 1) * n].reshape(P, n), axis=1) * (2 / n)
    Y = np.fft.rfft(y[n:(P + 1) * n].reshape(P, n), axis=1) * (2 / n)
    Um, Ym = U.mean(axis=0), Y.mean(axis=0)
    noise_y = np.var(Y, axis=0, ddof=1) / P               # noise variance of the mean
    pu = np.abs(Um) ** 2
    lines = np.arange(Um.size)
    excited = np.flatnonzero((pu > 1e-4 * pu.max()) & (lines > 0))
    if excited.size < 2:
        raise InputError("the drive excites fewer than two lines: not a multisine", field="drive")
    lo, hi = int(excited.min()), int(excited.max())
    base = np.gcd.reduce(excited)
    band_lines = np.arange(lo, hi + 1)
    band_lines = band_lines[band_lines % base == 0] if base > 1 else band_lines
    free = np.setdiff1d(band_lines, excited)
    unit = base
    odd = free[(free // unit) % 2 == 1]
    even = free[(free // unit) % 2 == 0]
    if base == 1:  # the grid's own unit: odd and even harmonics of the period's line
        odd, even = free[free % 2 == 1], free[free % 2 == 0]
    G = Ym[excited] / Um[excited]
    G_std = np.sqrt(noise_y[excited] / 2) / np.abs(Um[excited])
    # the stochastic nonlinear contribution at the excited lines, from the neighbouring
    # odd detection lines (the odd distortion lands on the odd lines, P&S Sec. 3.6)
    if odd.size:
        p_nl = np.maximum(np.abs(Ym[odd]) ** 2 - noise_y[odd], 0.0)
        var_nl = np.interp(excited, odd, p_nl)
    else:
        var_nl = np.zeros(excited.size)
    G_total = np.sqrt((noise_y[excited] + var_nl) / 2) / np.abs(Um[excited])
    edges = np.linspace(lo, hi + 1, bands + 1)
    rows = []
    for a, b in zip(edges, edges[1:]):
        sel = lambda idx: idx[(idx >= a) & (idx < b)]  # noqa: E731
        o, e, al = sel(odd), sel(even), sel(np.arange(lo, hi + 1))
        noise = float(np.mean(noise_y[al])) if al.size else np.nan
        db = lambda idx: (float(10 * np.log10(np.mean(np.abs(Ym[idx]) ** 2) / noise))  # noqa: E731
                          if idx.size and noise > 0 else None)
        rows.append({"from_hz": a * fs / n, "to_hz": b * fs / n, "odd_db": db(o), "even_db": db(e),
                     "odd_lines": int(o.size), "even_lines": int(e.size),
                     "noise_rms": float(np.sqrt(noise)) if np.isfinite(noise) else None})
    return {"period_samples": n, "periods": P, "excited_lines": int(excited.size),
            "bla": {"frequency_hz": (excited * fs / n).tolist(), "re": G.real.tolist(),
                    "im": G.imag.tolist(), "std": G_std.tolist(), "std_total": G_total.tolist()},
            "bands": rows, "summary": summary(rows)}


def summary(rows: list[dict[str, Any]]) -> str:
    """One phrase: which kinds of nonlinear distortion stand above the noise, where."""
    best: dict[str, tuple[float, float]] = {}
    for kind in ("even", "odd"):
        vals = [(r[f"{kind}_db"], 0.5 * (r["from_hz"] + r["to_hz"])) for r in rows
                if r[f"{kind}_db"] is not None]
        if vals:
            best[kind] = max(vals)
    found = [k for k in ("even", "odd") if k in best and best[k][0] >= DETECT_DB]
    if not found:
        top = max(best.values()) if best else (float("nan"), float("nan"))
        return f"no nonlinear distortion above the noise (at most {top[0]:.1f} dB)"
    db, hz = max(best[k] for k in found)
    return f"nonlinear, {' and '.join(found)}, {db:.1f} dB above the noise near {hz:.4g} Hz"
