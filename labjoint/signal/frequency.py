"""Excitation frequency of a record without frequency metadata."""

from __future__ import annotations

import numpy as np

from labjoint.errors import InputError
from labjoint.signal import validate


def estimate_frequency(x: np.ndarray, fs: float, *, min_hz: float | None = None,
                       max_hz: float | None = None) -> float:
    """Frequency (Hz) of the strongest spectral line of ``x`` (the fundamental).

    Coarse: peak of the Hann-windowed, 2x zero-padded FFT with Gaussian (log-parabolic)
    interpolation. Fine: least-squares slope of the phase of ``x`` demodulated at the
    coarse frequency over whole-period segments (which also rejects harmonics). On a
    clean sine of a few hundred cycles the relative error is far below 1e-6.

    >>> fs = 50_000.0
    >>> t = np.arange(100_000) / fs
    >>> x = np.sin(2 * np.pi * 401.3 * t) + 0.3 * np.sin(2 * np.pi * 3 * 401.3 * t)
    >>> round(estimate_frequency(x, fs), 4)
    401.3
    """
    fs = validate.sample_rate(fs)
    x = validate.signal(x, "x", min_samples=32)
    x = x - x.mean()
    n = x.size
    if not np.any(x):
        raise InputError("is constant: no frequency to estimate", field="x")
    nfft = 1 << int(np.ceil(np.log2(2 * n)))
    spec = np.abs(np.fft.rfft(x * np.hanning(n), nfft))
    freqs = np.arange(spec.size) * fs / nfft
    lo = 3.0 * fs / n if min_hz is None else validate.positive(min_hz, "min_hz")
    hi = fs / 2 if max_hz is None else validate.positive(max_hz, "max_hz")
    band = np.flatnonzero((freqs >= lo) & (freqs <= hi))
    band = band[(band > 0) & (band < spec.size - 1)]
    if band.size == 0:
        raise InputError(f"no frequency bin between {lo:g} and {hi:g} Hz for {n} samples",
                         field="x")
    k = int(band[np.argmax(spec[band])])
    a, b, c = np.log(np.maximum(spec[k - 1:k + 2], np.finfo(float).tiny))
    denom = a - 2 * b + c
    delta = 0.5 * (a - c) / denom if denom < 0 else 0.0
    f = (k + delta) * fs / nfft
    for _ in range(2):
        f = _refine_by_phase_slope(x, fs, f)
    return float(f)


def _refine_by_phase_slope(x: np.ndarray, fs: float, f0: float) -> float:
    """One step of f0 + (slope of the demodulated phase) / 2 pi, over whole periods."""
    n = x.size
    n_cycles = n * f0 / fs
    if n_cycles < 4:
        return f0
    periods = max(1, int(n_cycles // 16))
    seg = int(round(periods * fs / f0))
    n_seg = n // seg
    if n_seg < 3:
        return f0
    idx = np.arange(n_seg * seg)
    z = (x[: n_seg * seg] * np.exp(-2j * np.pi * ((idx * (f0 / fs)) % 1.0))).reshape(n_seg, seg)
    c = z.sum(axis=1)
    weight = np.abs(c)
    if not np.all(weight > 0):
        return f0
    phase = np.unwrap(np.angle(c))
    centre = np.arange(n_seg) * seg + (seg - 1) / 2.0
    slope = np.polyfit(centre, phase, 1, w=weight)[0]          # rad per sample
    return f0 + slope * fs / (2 * np.pi)
