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

from functools import lru_cache

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
        self._w = np.empty(0, dtype=complex)
        self._c2 = np.empty(0, dtype=complex)

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
            self._rot = _rotation(self._cps, 1 << max(int(x.size - 1).bit_length(), 10))
        n = self._tail.size + x.size
        if self._w.size < n:                             # work arrays, reused
            self._w = np.empty(n, dtype=np.complex128)
            self._c2 = np.empty(n + 2, dtype=np.complex128)
        w, c2 = self._w[:n], self._c2[:n + 2]
        _demodulate_sums(self._tail, x, self._rot, start, w, c2)
        w_start = self._n - w.size
        L, D = self.period_samples, self.step
        c_first = -(-(w_start + L - 1) // D) * D         # first grid centre with a full window
        c_last = self._n - L                             # last centre with a full window
        if c_last < c_first:
            self._tail = w.copy()
            return np.empty(0)
        count = (c_last - c_first) // D + 1
        centres = c_first + D * np.arange(count, dtype=np.float64)
        # two cascaded L-sample boxcars = triangle: sum via a double cumulative sum
        theta = _grid_phase(c2, c_first - (L - 1) - w_start, count, D, L,
                            self._theta if self._theta is not None else np.nan)
        nxt = c_first + (count - 1) * D + D
        self._tail = w[nxt - (L - 1) - w_start:].copy()
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
        bounds, self._m, self._last_index = _crossing_bounds(centres, theta, self._cps,
                                                             self._m, self._last_index)
        return bounds


@lru_cache(maxsize=8)
def _rotation(cps: float, n: int) -> np.ndarray:
    """exp(-i 2 pi cps j), j < n (read-only, shared by segmenters of the same ratio)."""
    rot = np.exp(-2j * np.pi * ((np.arange(n) * cps) % 1.0))
    rot.flags.writeable = False
    return rot


@njit(cache=True, nogil=True)
def _grid_phase(c2, p0, count, step, L, ref):  # pragma: no cover - compiled
    """Unwrapped phase of the triangle-window sums at ``count`` grid centres.

    Centre k's window starts at ``p0 + k step`` in ``c2`` (the double cumulative sum);
    the phase is unwrapped as ``np.unwrap`` does, continuing from ``ref`` (NaN: from
    the first centre itself).
    """
    theta = np.empty(count)
    for k in range(count):
        p = p0 + k * step
        z = c2[p + 2 * L] - 2 * c2[p + L] + c2[p]
        theta[k] = np.arctan2(z.imag, z.real)
    prev = theta[0] if np.isnan(ref) else ref
    shift = 0.0                                  # np.unwrap: the corrections' running sum
    for k in range(count):
        raw = theta[k]
        dd = raw - prev
        if abs(dd) >= np.pi:
            dmod = (dd + np.pi) % (2 * np.pi) - np.pi
            if dmod == -np.pi and dd > 0:
                dmod = np.pi
            shift += dmod - dd
        prev = raw
        theta[k] = raw + shift
    return theta


@njit(cache=True, nogil=True)
def _crossing_bounds(centres, theta, cps, prev_m, prev_i):  # pragma: no cover - compiled
    """Boundaries where the running maximum of the cycle coordinate passes an integer,
    interpolated linearly between centres; with the running maximum and its index."""
    n = centres.size
    out = np.empty(n + 1)
    found = 0
    m_prev, i_prev = prev_m, prev_i
    for k in range(n):
        coord = centres[k] * cps + (theta[k] + np.pi / 2) / (2 * np.pi)
        m = coord if coord > m_prev else m_prev
        lo_level = np.floor(m_prev)
        level = np.floor(m)
        if level > lo_level and np.isfinite(m_prev):
            frac = min(max((level - m_prev) / (m - m_prev), 0.0), 1.0)
            b = i_prev + frac * (centres[k] - i_prev)
            if b >= 1.0:
                out[found] = b
                found += 1
        m_prev, i_prev = m, centres[k]
    return out[:found], m_prev, i_prev


@njit(cache=True, nogil=True)
def _demodulate_sums(tail, x, rot, start, w, c2):  # pragma: no cover - compiled
    """``w`` = tail + x demodulated (x exp(-i 2 pi f t)), and ``c2`` its double
    cumulative sum with leading zeros (``c2[q] = sum_{r<q} sum_{j<r} w[j]``, q <= n + 1),
    in one pass, into the given arrays (n and n + 2 long).
    """
    nt = tail.size
    n = nt + x.size
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
