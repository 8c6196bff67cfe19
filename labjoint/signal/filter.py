"""Zero-phase Butterworth low-pass (seed 002: 5th order, 3 kHz), whole or streamed.

Design choice (seed 002 followed literally): the Butterworth prototype has its -3 dB
point at ``cutoff_hz``; forward-backward filtering (``sosfiltfilt``) squares the
magnitude, so the combined, zero-phase response is -6.02 dB (|H|^2 = 1/2) at the
cutoff and ``1 / (1 + (f/fc)^(2 order))`` elsewhere. At the 400 Hz fundamental of the
paper this is 1 - 2e-9: the fundamental and loop area are untouched, harmonics up to
~2 kHz pass with < 2 % loss.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy import signal as sps

from labjoint.errors import InputError
from labjoint.signal import validate
from labjoint.signal.lanes import filtfilt_pieces
from labjoint.signal.lanes import padlen as _padlen

PAPER_CUTOFF_HZ = 3000.0
PAPER_ORDER = 5
#: analyze() lowers the cutoff to this fraction of the sample rate when 3 kHz is too high.
MAX_CUTOFF_FRACTION = 0.45
#: Independent filter chains the compiled pass runs side by side: two AVX-512 vectors (or
#: four AVX2 ones) of float64, enough to hide the latency of each section's recursion.
LANES = 16


def butter_sos(fs: float, cutoff_hz: float = PAPER_CUTOFF_HZ, order: int = PAPER_ORDER) -> np.ndarray:
    """Second-order sections of a digital Butterworth low-pass (-3 dB at ``cutoff_hz``).

    >>> butter_sos(50_000.0).shape
    (3, 6)
    """
    fs = validate.sample_rate(fs)
    cutoff = validate.positive(cutoff_hz, "cutoff_hz")
    if cutoff >= fs / 2:
        raise InputError(f"must be below the Nyquist frequency fs/2 = {fs / 2:g} Hz, "
                         f"got {cutoff:g} Hz", field="cutoff_hz")
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 1 <= order <= 12:
        raise InputError(f"must be an integer from 1 to 12, got {order!r}", field="order")
    return sps.butter(int(order), cutoff, btype="low", fs=fs, output="sos")


def lowpass(x: np.ndarray, fs: float, cutoff_hz: float = PAPER_CUTOFF_HZ,
            order: int = PAPER_ORDER, axis: int = -1) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` along ``axis`` (seed 002, Sec. IV.A).

    The combined response is |H(f)|^2, i.e. -6.02 dB at ``cutoff_hz`` (see module doc).

    >>> t = np.arange(5000) / 50_000.0
    >>> y = lowpass(np.sin(2 * np.pi * 400 * t), 50_000.0)
    >>> bool(np.allclose(y[500:-500], np.sin(2 * np.pi * 400 * t)[500:-500], atol=1e-6))
    True
    """
    sos = butter_sos(fs, cutoff_hz, order)
    arr = validate.signal(x, "x", ndim=(1, 2, 3))
    axis = axis % arr.ndim
    if arr.shape[axis] <= _padlen(sos):
        raise InputError(f"needs more than {_padlen(sos)} samples along axis {axis} for "
                         f"zero-phase filtering, got {arr.shape[axis]}", field="x")
    return sps.sosfiltfilt(sos, arr, axis=axis)


def analysis_cutoff(fs: float, cutoff_hz: float | None = PAPER_CUTOFF_HZ) -> tuple[float | None, str]:
    """The cutoff analyze() uses: ``min(cutoff_hz, 0.45 fs)`` and the rule, stated.

    >>> analysis_cutoff(50_000.0)
    (3000.0, 'cutoff_hz = 3000 Hz as requested')
    >>> analysis_cutoff(5_000.0)[0]
    2250.0
    """
    fs = validate.sample_rate(fs)
    if cutoff_hz is None:
        return None, "no low-pass filter (cutoff_hz=None)"
    cutoff = validate.positive(cutoff_hz, "cutoff_hz")
    limit = MAX_CUTOFF_FRACTION * fs
    if cutoff > limit:
        return limit, (f"cutoff_hz lowered from {cutoff:g} Hz to {MAX_CUTOFF_FRACTION:g} fs = "
                       f"{limit:g} Hz because the sample rate is {fs:g} Hz")
    return cutoff, f"cutoff_hz = {cutoff:g} Hz as requested"


def settling_samples(sos: np.ndarray, rtol: float = 1e-12) -> int:
    """Samples after which a wrong initial filter state has decayed below ``rtol``.

    Closed form, bounded for any ratio of cutoff to sample rate: the step response's
    error is ``e[n] = sum_k R_k p_k^(n+1)`` over the poles ``p_k`` (partial fractions of
    ``H(z) / (1 - 1/z)``), so ``|e[n]| <= (sum_k |R_k|) r^(n+1)`` with ``r = max |p_k|``;
    the first ``n`` where that bound is below ``rtol`` (a state mismatch as large as the
    signal itself), plus the edge padding ``sosfiltfilt`` adds, is the overlap between
    chunks. Float64 round-off of the coefficients (about 1e-12 of the signal at 2 MS/s
    and a 3 kHz cutoff) is a floor no overlap removes; it does not grow with length.

    >>> settling_samples(butter_sos(50_000.0))
    282
    >>> settling_samples(butter_sos(2_000_000.0)) < 20_000     # 5 ms of samples
    True
    """
    rtol = validate.positive(rtol, "rtol")
    z, p, k, delay = _zpk(np.asarray(sos, dtype=np.float64))
    p = p[np.abs(p) > 1e-12]                    # poles at the origin settle in one step
    if p.size == 0:                             # FIR sections: settle within their length
        return 3 * len(sos) + _padlen(sos) + 8
    r = float(np.abs(p).max())
    if not r < 1.0:
        raise InputError(f"filter is not stable (pole radius {r:.6g} >= 1)", field="sos")
    total = 0.0
    for i, pk in enumerate(p):
        others = np.delete(p, i)
        den = np.prod(1.0 - others / pk) * (1.0 - 1.0 / pk)
        if abs(den) < 1e-300:                   # repeated poles: no partial fractions
            total = np.inf
            break
        total += abs(k * np.prod(1.0 - z / pk) / den / pk ** delay)
    if not np.isfinite(total):                  # bound n r^n instead, generously
        total = 1e6
    n = max(int(np.ceil(np.log(rtol / max(total, rtol)) / np.log(r))), 0)
    return n + _padlen(sos) + 8


def filtfilt_rows(sos: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``sosfiltfilt`` along the last axis of a (rows, n) array, bit for bit.

    Same odd-extension padding, initial states and direct-form-II-transposed sections
    as scipy's ``sosfiltfilt``, in compiled passes per direction (three sections at a
    time) with the rows side by side in SIMD lanes (:mod:`labjoint.signal.lanes`).

    >>> sos = butter_sos(50_000.0)
    >>> x = np.random.default_rng(0).standard_normal((2, 40_000))
    >>> bool(np.array_equal(filtfilt_rows(sos, x), sps.sosfiltfilt(sos, x, axis=-1)))
    True
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] <= _padlen(sos) or not np.all(sos[:, 3] == 1.0):
        return sps.sosfiltfilt(sos, x, axis=-1)
    return filtfilt_pieces(sos, x)[0]


def _zpk(sos: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Zeros, poles, gain and pure delay (samples) of cascaded sections, per section.

    Root-finding section by section stays well conditioned where scipy's ``sos2zpk``
    warns (a 3 kHz cutoff at 10 MS/s).
    """
    zeros, poles, gain, delay = [], [], 1.0, 0
    for sec in sos:
        b, a = np.trim_zeros(sec[:3], "b"), np.trim_zeros(sec[3:], "b")
        lead = int(np.flatnonzero(b)[0]) if b.any() else 0
        b = b[lead:]
        delay += lead
        gain *= b[0] / a[0] if b.size else 0.0
        zeros.append(np.roots(b))
        poles.append(np.roots(a))
    return np.concatenate(zeros), np.concatenate(poles), gain, delay


@lru_cache(maxsize=64)
def stream_design(fs: float, cutoff_hz: float = PAPER_CUTOFF_HZ, order: int = PAPER_ORDER,
                  rtol: float = 1e-12) -> tuple[np.ndarray, int, np.ndarray]:
    """The design a :class:`ZeroPhaseStream` needs: :func:`butter_sos`, its
    :func:`settling_samples` and scipy's ``sosfilt_zi``; made once per (fs, cutoff,
    order, rtol) and reused (a few milliseconds of scipy per design, against ~100 ms
    for analysing a minute of record). Callers copy the arrays before changing them.

    >>> stream_design(50_000.0)[1]
    282
    """
    sos = butter_sos(fs, cutoff_hz, order)
    return sos, settling_samples(sos, rtol), sps.sosfilt_zi(sos)


class ZeroPhaseStream:
    """Zero-phase low-pass of a record arriving in blocks, with bounded memory.

    Each output stretch is filtered together with ``overlap`` raw samples on both
    sides, and the first/last stretch include the record's own ends, so the output
    equals :func:`lowpass` of the whole record to ``rtol`` relative (seed 002 filter).
    Blocks are ``(n_channels, n)``; :meth:`push` returns the samples now final,
    :meth:`finish` the rest. Output lags input by about ``overlap + min_chunk`` samples.
    """

    def __init__(self, fs: float, cutoff_hz: float = PAPER_CUTOFF_HZ, order: int = PAPER_ORDER,
                 *, min_chunk: int = 65536, rtol: float = 1e-12) -> None:
        sos, self.overlap, zi = stream_design(fs, cutoff_hz, order, rtol)
        self.sos, self._zi = sos.copy(), zi.copy()      # the cached design stays untouched
        self.min_chunk = max(int(min_chunk), self.overlap)
        self._pending: list[np.ndarray] = []
        self._pending_n = 0
        self._buf_start = 0          # absolute index of the first raw sample held
        self._out = 0                # absolute index of the next output sample
        self._work: np.ndarray | None = None      # the lanes' scratch, reused
        self._raw: np.ndarray | None = None       # chunks joined here, reused
        self._rows = 0

    def push(self, block: np.ndarray) -> np.ndarray:
        """Add a block (n_channels, n); return the filtered samples that are now final."""
        block = np.atleast_2d(block)
        self._rows = block.shape[0]
        self._pending.append(block)
        self._pending_n += block.shape[1]
        end = self._buf_start + self._pending_n
        if end - self._out < self.overlap + self.min_chunk:
            return np.empty((block.shape[0], 0))
        return self._emit(final=False)

    def finish(self) -> np.ndarray:
        """Filter and return the remaining samples (the record's end is the segment end)."""
        if not self._pending:
            return np.empty((0, 0))
        if self._out == 0 and self._pending_n <= _padlen(self.sos):
            raise InputError(f"record has {self._pending_n} samples; zero-phase filtering "
                             f"needs more than {_padlen(self.sos)}", field="blocks")
        return self._emit(final=True)

    def _emit(self, *, final: bool) -> np.ndarray:
        n = self._pending_n
        if len(self._pending) == 1:
            raw = self._pending[0]
        else:                                   # joined in a reused buffer
            if self._raw is None or self._raw.shape[1] < n or self._raw.shape[0] != self._rows:
                self._raw = np.empty((self._rows, n))
            raw = np.concatenate(self._pending, axis=1, out=self._raw[:, :n])
        end = self._buf_start + n
        stop = end if final else end - self.overlap
        out = self._filter(raw, (self._out - self._buf_start, stop - self._buf_start))
        self._out = stop
        keep_from = max(stop - self.overlap, self._buf_start)
        tail = raw[:, keep_from - self._buf_start:].copy()
        self._pending = [tail] if not final else []
        self._pending_n = tail.shape[1] if not final else 0
        self._buf_start = keep_from
        return out

    def _filter(self, raw: np.ndarray, keep: tuple[int, int]) -> np.ndarray:
        """Samples ``keep`` of the zero-phase filtered chunk ``raw``: its rows cut into
        pieces that overlap by twice the settling length (each at least 8 settling
        lengths long), so up to :data:`LANES` chains run side by side
        (:func:`labjoint.signal.lanes.filtfilt_pieces`); equal to filtering the chunk
        whole within ``rtol``, like the stream's joints."""
        rows, n = raw.shape
        if not np.all(self.sos[:, 3] == 1.0):       # not from butter_sos: scipy's own
            return sps.sosfiltfilt(self.sos, raw, axis=-1)[:, keep[0]:keep[1]]
        pieces = max(1, min(LANES // rows, n // (8 * self.overlap)))
        out, self._work = filtfilt_pieces(self.sos, raw, pieces,
                                          self.overlap if pieces > 1 else 0, keep=keep,
                                          zi=self._zi, work=self._work)
        return out
