"""Frequency response function of a record: response over force, H1 estimate.

- Periodic excitation (a multisine whose period is a whole number of samples, two or
  more whole periods after the first, which holds the start-up transient): the DFT of
  every steady period at the excited lines; H1 = sum_p Y_p conj(F_p) / sum_p |F_p|^2 over
  the periods p, and the coherence from the same sums (Pintelon and Schoukens' averaged
  periodic FRF; exact for a linear system without noise, no leakage).
- Otherwise: Welch's H1 = S_fy / S_ff with Hann windows of 2^k samples (about an eighth
  of the record, at least 256), half overlap; coherence |S_fy|^2 / (S_ff S_yy).

>>> fs = 1000.0
>>> t = np.arange(8 * 1000) / fs
>>> f = np.sin(2 * np.pi * 50 * t) + np.sin(2 * np.pi * 120 * t)
>>> r = frf_h1(f, 2.0 * f, fs)
>>> bool(np.allclose(r.h[r.coherence > 0.99], 2.0))
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal as sps

from labjoint.signal import validate
from labjoint.signal.excitation import Excitation, detect_excitation


@dataclass(frozen=True)
class FRF:
    """An FRF estimate: frequencies (Hz), complex H (response unit / force unit),
    coherence (0..1) and the method in words."""

    freq_hz: np.ndarray
    h: np.ndarray
    coherence: np.ndarray
    method: str


def frf_h1(force: np.ndarray, response: np.ndarray, fs: float,
           excitation: Excitation | None = None) -> FRF:
    """H1 of ``response`` over ``force`` (module docstring)."""
    fs = validate.sample_rate(fs)
    f = validate.signal(force, "force", min_samples=16)
    y = validate.signal(response, "response", min_samples=16)
    validate.same_length(f, y, "force", "response")
    exc = excitation or detect_excitation(f, fs)
    per = exc.period_s * fs if exc.kind == "multisine" and exc.period_s else 0.0
    n = int(round(per))
    if n and abs(per - n) < 1e-6 * n and f.size // n >= 3:
        return _periodic(f, y, fs, n)
    return _welch(f, y, fs)


def _periodic(f: np.ndarray, y: np.ndarray, fs: float, n: int) -> FRF:
    k = f.size // n
    F = np.fft.rfft(f[n:k * n].reshape(k - 1, n), axis=1)
    Y = np.fft.rfft(y[n:k * n].reshape(k - 1, n), axis=1)
    pf = np.sum(np.abs(F) ** 2, axis=0)
    lines = np.flatnonzero(pf > 1e-6 * pf.max())
    lines = lines[lines > 0]
    sfy = np.sum(Y[:, lines] * np.conj(F[:, lines]), axis=0)
    syy = np.sum(np.abs(Y[:, lines]) ** 2, axis=0)
    h = sfy / pf[lines]
    coh = np.abs(sfy) ** 2 / (pf[lines] * syy)
    return FRF(lines * fs / n, h, np.clip(coh, 0.0, 1.0),
               f"H1 over {k - 1} steady periods of {n} samples at the {lines.size} excited lines")


def _welch(f: np.ndarray, y: np.ndarray, fs: float) -> FRF:
    nper = max(256, 1 << int(np.floor(np.log2(max(f.size // 8, 1)))))
    nper = min(nper, f.size)
    fr, sff = sps.welch(f, fs, window="hann", nperseg=nper)
    _, sfy = sps.csd(f, y, fs, window="hann", nperseg=nper)
    _, syy = sps.welch(y, fs, window="hann", nperseg=nper)
    ok = sff > 1e-12 * sff.max()
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where(ok, sfy / sff, np.nan)
        coh = np.where(ok & (syy > 0), np.abs(sfy) ** 2 / (sff * syy), 0.0)
    keep = ok & (fr > 0)
    return FRF(fr[keep], h[keep], np.clip(coh[keep], 0.0, 1.0),
               f"Welch H1, Hann windows of {nper} samples, half overlap")
