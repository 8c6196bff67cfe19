"""Online analysis while acquiring: fundamental phasors and a per-cycle steady-state check.

Kept deliberately simple (the full steady-state detector lives in ``labjoint.signal``,
a higher layer the engine cannot use). The fundamental of a record is found by least
squares on ``a cos(wt) + b sin(wt) + c``, which is exact for a window of any length
(no leakage when a cycle is not a whole number of samples).
"""

from __future__ import annotations

import numpy as np


def fundamental(x: np.ndarray, sample_rate_hz: float, frequency_hz: float,
                first_sample: int = 0) -> np.ndarray:
    """Complex amplitude X of each row at ``frequency_hz``: x(t) ~ Re(X exp(i w t)) + c.

    ``t = (first_sample + k) / sample_rate_hz``; ``|X|`` is the amplitude (peak), and
    ``angle(X)`` the phase of a cosine at t = 0.

    >>> t = np.arange(100) / 1000.0
    >>> X = fundamental(np.array([3.0 * np.cos(2 * np.pi * 40 * t - 0.5) + 1.0]), 1000.0, 40.0)
    >>> round(float(abs(X[0])), 9), round(float(np.angle(X[0])), 9)
    (3.0, -0.5)
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    n = x.shape[1]
    if n < 3:
        raise ValueError(f"need at least 3 samples for a fundamental fit, got {n}")
    w = 2.0 * np.pi * frequency_hz / sample_rate_hz
    k = first_sample + np.arange(n, dtype=float)
    basis = np.column_stack([np.cos(w * k), np.sin(w * k), np.ones(n)])
    coef, *_ = np.linalg.lstsq(basis, x.T, rcond=None)
    return coef[0] - 1j * coef[1]


class CycleAmplitudes:
    """Per-cycle fundamental amplitude of some channels, fed block by block.

    Cycle ``k`` spans samples ``[s0 + round(k N), s0 + round((k + 1) N))`` with
    ``N = fs / f`` and ``s0`` the first sample fed; ``scale`` turns volts into SI units.
    With ``rms`` a cycle's amplitude is sqrt(2) times its RMS about its mean (a whole
    period of any periodic drive; the fundamental's amplitude for a pure sine).
    """

    def __init__(self, frequency_hz: float, sample_rate_hz: float, scale: np.ndarray,
                 rms: bool = False) -> None:
        self.rms = bool(rms)
        self.frequency_hz = float(frequency_hz)
        self.sample_rate_hz = float(sample_rate_hz)
        self.scale = np.asarray(scale, dtype=float)
        self.history: list[np.ndarray] = []
        self._start: int | None = None
        self._buf = np.empty((len(self.scale), 0))
        self._buf_first = 0

    @property
    def samples_per_cycle(self) -> float:
        return self.sample_rate_hz / self.frequency_hz

    def _boundary(self, k: int) -> int:
        return int(self._start + round(k * self.samples_per_cycle))

    def feed(self, volts: np.ndarray, first_sample: int) -> int:
        """Add a block (rows: the tracked channels); return how many cycles completed."""
        volts = np.asarray(volts, dtype=float)
        if self._start is None or first_sample != self._buf_first + self._buf.shape[1]:
            self._start, self._buf, self._buf_first = first_sample, volts[:, :0], first_sample
            self.history = []
        self._buf = np.concatenate([self._buf, volts], axis=1)
        done = 0
        while True:
            k = len(self.history)
            a, b = self._boundary(k), self._boundary(k + 1)
            if self._buf_first + self._buf.shape[1] < b:
                return done
            seg = self._buf[:, a - self._buf_first: b - self._buf_first]
            if self.rms:
                amp = np.sqrt(2.0 * np.mean((seg - seg.mean(axis=1, keepdims=True)) ** 2, axis=1))
            else:
                amp = np.abs(fundamental(seg, self.sample_rate_hz, self.frequency_hz, first_sample=a))
            self.history.append(amp * np.abs(self.scale))
            self._buf, self._buf_first = self._buf[:, b - self._buf_first:], b
            done += 1

    def drift(self, window: int) -> float:
        """Largest relative change of the amplitude across the last ``window`` cycles,
        from a least-squares line through them: |slope| (window - 1) / mean (inf if
        fewer cycles). A line fit averages the noise of single cycles, which a max-min
        range would not (its noise is about 3x larger over 10 cycles)."""
        if len(self.history) < window:
            return float("inf")
        a = np.array(self.history[-window:])
        k = np.arange(window) - (window - 1) / 2.0
        slope = k @ a / (k @ k)
        mean = a.mean(axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(mean > 0, np.abs(slope) * (window - 1) / mean, np.inf)
        return float(rel.max())


class FrequencyTracker:
    """The drive frequency on the DAQ's clock, from one channel fed block by block.

    The generator's and the DAQ's clocks differ by tens of ppm (a USB cDAQ timebase is
    specified to +-50 ppm), so over a long record the set frequency drifts away from the
    one in the samples. Each block's phase at the nominal frequency ``f0`` (referred to
    the task's sample 0) advances by 2 pi (f - f0) per second; the slope of a weighted
    least-squares line through the unwrapped phases gives f and its standard error.

    >>> fs, f = 10000.0, 400.0 * (1 + 50e-6)
    >>> tr = FrequencyTracker(400.0, fs)
    >>> for first in range(0, 50000, 1000):
    ...     k = first + np.arange(1000)
    ...     tr.feed(np.cos(2 * np.pi * f * k / fs + 0.3), first)
    >>> round(tr.estimate()[0], 5)
    400.02
    """

    def __init__(self, nominal_hz: float, sample_rate_hz: float) -> None:
        self.f0, self.fs = float(nominal_hz), float(sample_rate_hz)
        self.t: list[float] = []
        self.phase: list[float] = []
        self.weight: list[float] = []

    def feed(self, x: np.ndarray, first_sample: int) -> None:
        """One block of the channel (volts) starting at the task's sample ``first_sample``."""
        n = int(np.size(x))
        if n * self.f0 / self.fs < 2.0:  # under two cycles: its phase says little
            return
        X = fundamental(np.asarray(x)[None, :], self.fs, self.f0, first_sample)[0]
        if abs(X) > 0:
            self.t.append((first_sample + 0.5 * (n - 1)) / self.fs)
            self.phase.append(float(np.angle(X)))
            self.weight.append(float(abs(X)) ** 2 * n)

    def estimate(self) -> tuple[float, float] | None:
        """(frequency_hz, its standard error) from three blocks on, else None."""
        if len(self.t) < 3:
            return None
        t, w = np.array(self.t), np.array(self.weight)
        phi = np.unwrap(np.array(self.phase))
        tm = np.average(t, weights=w)
        sxx = float(np.sum(w * (t - tm) ** 2))
        if not sxx > 0:
            return None
        slope = float(np.sum(w * (t - tm) * (phi - np.average(phi, weights=w))) / sxx)
        resid = phi - np.average(phi, weights=w) - slope * (t - tm)
        var = float(np.sum(w * resid ** 2)) / ((len(t) - 2) * sxx)  # slope variance
        return self.f0 + slope / (2 * np.pi), float(np.sqrt(max(var, 0.0))) / (2 * np.pi)
