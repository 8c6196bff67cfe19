"""Mains hum: find the 50/60 Hz lines (and harmonics) in a record and take them out.

Hum on a channel is a disturbance no joint model predicts, and it is not what the noise
floor's cycle-to-cycle scatter measures: within the few cycles of a noise window a 50 Hz
line under a 600 Hz drive moves smoothly and counts as drift. Left in, it raises the
residual above the floor and a model that explains the joint looks inadequate.

Method (stated): for each mains harmonic h f_0 (f_0 = 50 and 60 Hz, h = 1..3) away from
the drive's harmonics (more than 4 bins, 4/T), the line's frequency is refined within
+-0.5 % on the Hann-windowed spectrum, its amplitude and phase are the Hann-weighted
least-squares sine at that frequency (the window keeps the drive's leakage out), and
it is removed only if it stands out: its power at least ``LINE_RATIO`` times the median
power of the neighbouring bins (5-40 bins away), and it is stationary: the sines fitted
on the two halves of the record differ by less than ``STATIONARY`` of it (a ramped
drive's skirt is not). The line is subtracted over the whole
record (hum is stationary over a record's seconds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAINS_HZ = (50.0, 60.0)
HARMONICS = 3
LINE_RATIO = 20.0
#: the line's sine fitted on each half of the record may differ by this fraction of it
STATIONARY = 0.3
#: records longer than this are estimated on their first part (the line is stationary)
MAX_ESTIMATE = 1 << 18


@dataclass(frozen=True)
class Line:
    """A removed line: frequency (Hz), amplitude (channel unit) and its power over the
    neighbouring bins' median."""

    frequency_hz: float
    amplitude: float
    ratio: float

    def to_dict(self) -> dict[str, float]:
        return {"frequency_hz": self.frequency_hz, "amplitude": self.amplitude,
                "ratio": self.ratio}


def remove_mains(x: np.ndarray, fs: float, drive_hz: float | None = None,
                 mains: tuple[float, ...] = MAINS_HZ) -> tuple[np.ndarray, list[Line]]:
    """``x`` without its significant mains lines, and the lines removed (module doc).

    >>> fs = 10_000.0
    >>> t = np.arange(5000) / fs
    >>> x = 50 * np.sin(2 * np.pi * 400 * t) + 1.5 * np.sin(2 * np.pi * 50 * t + 1.0)
    >>> y, lines = remove_mains(x + np.random.default_rng(0).normal(0, 0.1, t.size), fs, 400.0)
    >>> [round(line.frequency_hz, 1) for line in lines], round(lines[0].amplitude, 1)
    ([50.0], 1.5)
    """
    x = np.asarray(x, dtype=float)
    n = min(x.size, MAX_ESTIMATE)
    if n < 64:
        return x, []
    seg = x[:n] - x[:n].mean()
    t = np.arange(n) / fs
    w = np.hanning(n)
    T = n / fs
    out = x.copy()
    t_all = np.arange(x.size) / fs
    lines: list[Line] = []
    for f0 in mains:
        for h in range(1, HARMONICS + 1):
            fh = h * f0
            if fh >= 0.45 * fs or fh * T < 4:
                continue
            if drive_hz and abs(fh - drive_hz * round(fh / drive_hz)) < 4.0 / T:
                continue
            grid = fh * (1.0 + np.linspace(-0.005, 0.005, 41))
            f = float(grid[np.argmax(_power(seg, w, t, grid))])
            near = f + np.concatenate([np.arange(-40, -4), np.arange(5, 41)]) / T
            near = near[near > 0]
            if drive_hz:
                k = np.round(near / drive_hz)
                near = near[np.abs(near - k * drive_hz) > 4.0 / T]
            floor = float(np.median(_power(seg, w, t, near))) if near.size else 0.0
            p = float(_power(seg, w, t, np.array([f]))[0])
            if floor <= 0 or p < LINE_RATIO * floor:
                continue
            coef = _sine(seg, t, w, f)
            half = n // 2
            wh = np.hanning(half)
            one = _sine(seg[:half], t[:half], wh, f)
            two = _sine(seg[half:2 * half], t[half:2 * half], wh, f)
            if np.hypot(*(one - two)) > STATIONARY * np.hypot(*coef):
                continue                  # not stationary: the drive's skirt, not hum
            out -= coef[0] * np.cos(2 * np.pi * f * t_all) + coef[1] * np.sin(2 * np.pi * f * t_all)
            lines.append(Line(f, float(np.hypot(*coef)), p / floor))
    return out, lines


def _sine(x: np.ndarray, t: np.ndarray, w: np.ndarray, f: float) -> np.ndarray:
    """[a, b] of the ``w``-weighted least-squares a cos + b sin at ``f`` (absolute time)."""
    c, s = np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)
    m = np.array([[w @ (c * c), w @ (c * s)], [w @ (c * s), w @ (s * s)]])
    return np.linalg.solve(m, np.array([w @ (c * x), w @ (s * x)]))


def _power(x: np.ndarray, w: np.ndarray, t: np.ndarray, freqs: np.ndarray) -> np.ndarray:
    """Hann-windowed DTFT power of ``x`` at ``freqs``."""
    xw = x * w
    return np.array([abs(np.sum(xw * np.exp(-2j * np.pi * f * t))) ** 2 for f in freqs])
