"""Frequency response function of a record: response over force, H1 estimate.

One response over one force, through the broadband estimator every FRF of labjoint uses
(:func:`labjoint.signal.broadband.estimate`: whole periods of a multisine at its excited
lines, one unwindowed block per burst with its free decay, Welch over the active part of
a steady random drive, one block for a sweep or an impact; a steady sine through Welch,
meaningful at its line only).

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

from labjoint.signal import validate
from labjoint.signal.broadband import estimate
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
    # a steady sine has no broadband FRF; Welch's, meaningful at its line, as before
    r = estimate(f, y[None, :], fs, excitation=exc, method="welch" if exc.kind == "sine" else "auto")
    return FRF(r.freq_hz, r.h[0], r.coherence[0], r.method)
