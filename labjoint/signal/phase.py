"""Cycle boundaries from the phase of the displacement's fundamental.

The record is demodulated at the excitation frequency f, z = x exp(-i 2 pi f t), and
averaged by two cascaded one-period boxcars. That keeps the slowly varying complex
amplitude A(t) = |A| exp(i theta) of the fundamental and rejects DC, drift, harmonics
(they land on multiples of f, the boxcar's zeros) and most noise. With the phase
psi = 2 pi f t + theta, the fundamental is |A| cos(psi); an upward zero crossing is
psi = -pi/2 (mod 2 pi), so cycle k starts where ``f t + (theta + pi/2) / 2 pi = k``.
theta is evaluated every 1/8 period and interpolated linearly between; within a window
of the record's ends it is extrapolated along its slope over the nearest period.
Raw zero crossings of noisy data are never used. Boundaries are fractional sample
indices; ``bounds[k]`` to ``bounds[k + 1]`` is cycle ``k``. The segmenter follows the
true fundamental even when ``frequency_hz`` is slightly off (theta then drifts).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from labjoint.errors import InputError
from labjoint.signal import validate

#: Fewer samples per period than this cannot be resampled reliably.
MIN_SAMPLES_PER_PERIOD = 4.0
#: Longest piece demodulated at once.
MAX_PIECE = 1 << 17


class CycleSegmenter:
    """Streaming cycle segmentation: feed blocks with :meth:`push`, then :meth:`finish`.

    Returns boundaries as absolute fractional sample indices, each once, increasing.
    The result equals :func:`segment_cycles` on the whole record (to rounding).
    """

    def __init__(self, fs: float, frequency_hz: float) -> None:
        self.fs = validate.sample_rate(fs)
        self.frequency_hz = validate.positive(frequency_hz, "frequency_hz")
        if self.fs / self.frequency_hz < MIN_SAMPLES_PER_PERIOD:
            raise InputError(f"{self.frequency_hz:g} Hz leaves fewer than "
                             f"{MIN_SAMPLES_PER_PERIOD:g} samples per period at fs = "
                             f"{self.fs:g} Hz", field="frequency_hz")
        self.period_samples = max(2, int(round(self.fs / self.frequency_hz)))
        #: the phase is evaluated every ``step`` samples and interpolated between
        self.step = max(1, self.period_samples // 8)
        self._cps = self.frequency_hz / self.fs          # cycles per sample
        self._n = 0                                      # samples received
        self._tail = np.empty(0, dtype=complex)          # demodulated samples still needed
        self._theta: float | None = None                 # last unwrapped phase
        self._theta_rate = 0.0                           # its slope, rad per sample
        self._m = -np.inf                                # running max of the cycle coordinate
        self._last_index = -1.0                          # sample index of self._m
        self._rot = np.empty(0, dtype=complex)

    def push(self, x: np.ndarray) -> np.ndarray:
        """Add samples; return the boundaries that are now known."""
        x = np.asarray(x, dtype=np.float64).ravel()
        if x.size > MAX_PIECE:                           # bounds memory and cumsum rounding
            return np.concatenate([self.push(x[i:i + MAX_PIECE])
                                   for i in range(0, x.size, MAX_PIECE)])
        first = self._n
        self._n += x.size
        start = np.exp(-2j * np.pi * ((first * self._cps) % 1.0))
        if self._rot.size < x.size:
            self._rot = np.exp(-2j * np.pi * ((np.arange(x.size) * self._cps) % 1.0))
        w, c2 = _demodulate_sums(self._tail, x, self._rot, start)
        w_start = self._n - w.size
        L, D = self.period_samples, self.step
        c_first = -(-(w_start + L - 1) // D) * D         # first grid centre with a full window
        c_last = self._n - L                             # last centre with a full window
        if c_last < c_first:
            self._tail = w
            return np.empty(0)
        centres = np.arange(c_first, c_last + 1, D)
        # two cascaded L-sample boxcars = triangle: sum via a double cumulative sum
        p = centres - (L - 1) - w_start
        theta = np.angle(c2[p + 2 * L] - 2 * c2[p + L] + c2[p])
        nxt = int(centres[-1]) + D
        self._tail = w[nxt - (L - 1) - w_start:].copy()
        centres = centres.astype(np.float64)
        ref = self._theta if self._theta is not None else theta[0]
        theta = np.unwrap(np.concatenate([[ref], theta]))[1:]
        if self._theta is None:                          # extrapolate the phase back to t=0
            head = np.arange(0.0, centres[0], D)
            rate = self._rate(centres, theta, first=True)
            centres = np.concatenate([head, centres])
            theta = np.concatenate([theta[0] + rate * (head - centres[head.size]), theta])
        self._theta = float(theta[-1])
        self._theta_rate = self._rate(centres, theta, first=False)
        return self._crossings(centres, theta)

    def _rate(self, centres: np.ndarray, theta: np.ndarray, *, first: bool) -> float:
        """Phase slope (rad/sample) over one period at the start or end of the centres."""
        k = min(self.period_samples // self.step, centres.size - 1)
        if k < 2:
            return 0.0
        i, j = (0, k) if first else (-1 - k, -1)
        return float((theta[j] - theta[i]) / (centres[j] - centres[i]))

    @property
    def settled_index(self) -> float:
        """No boundary found later can lie before this sample index."""
        return max(self._last_index, 0.0)

    def finish(self) -> np.ndarray:
        """Boundaries in the last samples, the phase extrapolated along its last slope."""
        if self._theta is None:
            return np.empty(0)
        centres = np.arange(self._last_index + self.step, self._n, self.step, dtype=np.float64)
        if centres.size == 0 or centres[-1] < self._n - 1:
            centres = np.append(centres, self._n - 1.0)
        theta = self._theta + self._theta_rate * (centres - self._last_index)
        out = self._crossings(centres, theta)
        return out[out <= self._n - 3]

    def _crossings(self, centres: np.ndarray, theta: np.ndarray) -> np.ndarray:
        coord = centres * self._cps + (theta + np.pi / 2) / (2 * np.pi)
        prev_m, prev_i = self._m, self._last_index
        m = np.maximum.accumulate(np.concatenate([[prev_m], coord]))
        idx = np.concatenate([[prev_i], centres])
        self._m, self._last_index = float(m[-1]), float(idx[-1])
        level = np.floor(m)
        step = np.flatnonzero(level[1:] > level[:-1]) + 1
        step = step[np.isfinite(m[step - 1])]
        lo, hi = m[step - 1], m[step]
        frac = np.clip((level[step] - lo) / (hi - lo), 0.0, 1.0)
        bounds = idx[step - 1] + frac * (idx[step] - idx[step - 1])
        return bounds[bounds >= 1.0]


@njit(cache=True, nogil=True)
def _demodulate_sums(tail, x, rot, start):  # pragma: no cover - compiled
    """``w`` = tail + x demodulated (x exp(-i 2 pi f t)), and ``c2`` its double
    cumulative sum with leading zeros (``c2[q] = sum_{r<q} sum_{j<r} w[j]``, q <= n + 1),
    in one pass.
    """
    nt = tail.size
    n = nt + x.size
    w = np.empty(n, dtype=np.complex128)
    c2 = np.empty(n + 2, dtype=np.complex128)
    w[:nt] = tail
    for j in range(x.size):
        w[nt + j] = x[j] * (start * rot[j])
    c1 = 0.0 + 0.0j
    acc = 0.0 + 0.0j
    c2[0] = acc
    for q in range(n):
        acc += c1
        c2[q + 1] = acc
        c1 += w[q]
    c2[n + 1] = acc + c1
    return w, c2


def segment_cycles(displacement: np.ndarray, fs: float, frequency_hz: float) -> np.ndarray:
    """Cycle boundaries (fractional sample indices) at upward zero crossings of the
    displacement's fundamental; ``bounds[k]:bounds[k+1]`` is cycle k.

    DC, slow drift, harmonics and noise are rejected by the demodulation (module doc),
    so raw or filtered, mean-removed or not, give the same boundaries.

    >>> fs, f = 50_000.0, 400.0
    >>> t = np.arange(5000) / fs                  # 40 periods of sin: crossings at k*125
    >>> b = segment_cycles(np.sin(2 * np.pi * f * t) + 0.2 * np.cos(6 * np.pi * f * t), fs, f)
    >>> b[:3].round(6).tolist(), b.size
    ([125.0, 250.0, 375.0], 39)
    """
    x = validate.signal(displacement, "displacement", min_samples=4)
    seg = CycleSegmenter(fs, frequency_hz)
    return np.concatenate([seg.push(x), seg.finish()])
