"""H1 frequency response from stepped-sine records (the ``broadband`` plan's runs).

The generator only makes sines, so the linear FRF is measured point by point: one
low-level steady record per frequency. Each record is cut into segments of whole drive
cycles; the fundamental phasors F_k (force) and X_k (response) of the segments give

    G_ff = sum |F_k|^2,   G_xf = sum X_k conj(F_k),   G_xx = sum |X_k|^2,
    H1 = G_xf / G_ff,     coherence = |G_xf|^2 / (G_ff G_xx)

(H1 is the receptance when the response is a displacement; seed 001 lists the FRF
types). Noise on the response averages out of H1; coherence near 1 means the response
is linear in the force and the noise small.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np

from labjoint.acquisition.online import fundamental
from labjoint.errors import InputError


@dataclass(frozen=True)
class FrfPoint:
    """H1 at one frequency, its coherence and how many segments were averaged."""

    frequency_hz: float
    h1: complex
    coherence: float
    n_segments: int


def frf_h1(force: np.ndarray, response: np.ndarray, sample_rate_hz: float, frequency_hz: float,
           cycles_per_segment: int = 5) -> FrfPoint:
    """H1 = G_xf / G_ff at ``frequency_hz`` from one stepped-sine record (SI arrays).

    >>> fs, f = 10000.0, 100.0
    >>> t = np.arange(5000) / fs
    >>> force = 2.0 * np.cos(2 * np.pi * f * t)
    >>> x = 1e-6 * np.cos(2 * np.pi * f * t - 0.3)
    >>> p = frf_h1(force, x, fs, f)
    >>> round(abs(p.h1) * 1e7, 6), round(float(np.angle(p.h1)), 6), round(p.coherence, 6)
    (5.0, -0.3, 1.0)
    """
    force, response = np.asarray(force, dtype=float), np.asarray(response, dtype=float)
    if force.shape != response.shape or force.ndim != 1:
        raise InputError(f"force and response must be 1-D arrays of equal length, got "
                         f"{force.shape} and {response.shape}", field="response")
    if not (sample_rate_hz > 0 and frequency_hz > 0 and frequency_hz < sample_rate_hz / 2):
        raise InputError(f"need 0 < frequency ({frequency_hz}) < sample rate / 2 ({sample_rate_hz / 2})",
                         field="frequency_hz")
    if cycles_per_segment < 1:
        raise InputError("must be at least 1", field="cycles_per_segment")
    seg = cycles_per_segment * sample_rate_hz / frequency_hz
    n_seg = int(len(force) // seg)
    if n_seg < 1:
        raise InputError(f"record of {len(force)} samples is shorter than one segment "
                         f"({seg:.0f} samples)", field="cycles_per_segment")
    F = np.empty(n_seg, dtype=complex)
    X = np.empty(n_seg, dtype=complex)
    for k in range(n_seg):
        a, b = int(round(k * seg)), int(round((k + 1) * seg))
        F[k], X[k] = fundamental(np.vstack([force[a:b], response[a:b]]), sample_rate_hz,
                                 frequency_hz, first_sample=a)
    g_ff = float(np.sum(np.abs(F) ** 2))
    g_xx = float(np.sum(np.abs(X) ** 2))
    g_xf = complex(np.sum(X * np.conj(F)))
    if g_ff == 0:
        raise InputError("the force has no component at the drive frequency", field="force")
    coherence = abs(g_xf) ** 2 / (g_ff * g_xx) if g_xx > 0 else 0.0
    return FrfPoint(float(frequency_hz), g_xf / g_ff, float(coherence), n_seg)


def stepped_frf(records: Iterable[tuple[float, np.ndarray, np.ndarray, float]],
                cycles_per_segment: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(frequencies, H1, coherence), sorted by frequency, from ``(frequency_hz, force,
    response, sample_rate_hz)`` per record."""
    pts = sorted((frf_h1(F, x, fs, f, cycles_per_segment) for f, F, x, fs in records),
                 key=lambda p: p.frequency_hz)
    if not pts:
        raise InputError("no records given", field="records")
    return (np.array([p.frequency_hz for p in pts]), np.array([p.h1 for p in pts]),
            np.array([p.coherence for p in pts]))
