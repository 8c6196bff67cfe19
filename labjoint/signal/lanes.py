"""Zero-phase IIR filtering with independent filter chains side by side in SIMD lanes.

The recursion of one chain of second-order sections cannot be vectorised, but the same
operations on independent chains can: rows, and pieces of a long row, are interleaved
sample by sample ("lanes"), so each section step of all lanes is a few vector
instructions. Each lane is exactly scipy's ``sosfiltfilt`` of its stretch (odd
extension, ``sosfilt_zi`` initial states, direct form II transposed): a whole row in one
lane is filtered bit for bit as scipy does it.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy import signal as sps


def padlen(sos: np.ndarray) -> int:
    """The default edge padding of scipy's ``sosfiltfilt`` for these sections."""
    zeros = min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    return 3 * (2 * len(sos) + 1 - zeros)


def filtfilt_pieces(sos: np.ndarray, x: np.ndarray, pieces: int = 1, overlap: int = 0, *,
                    keep: tuple[int, int] | None = None, zi: np.ndarray | None = None,
                    work: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Zero-phase filtering of the rows of ``x`` (rows, n) and the scratch array used.

    Each row is cut into ``pieces`` stretches that reach ``overlap`` samples past their
    joins; every stretch is filtered on its own (as ``sosfiltfilt`` would filter it) in
    its own lane, and its output is kept between its joins. With ``overlap`` at least
    the filter's settling length the result equals filtering each row whole within that
    length's tolerance; ``pieces=1`` is ``sosfiltfilt`` bit for bit. Every stretch must
    be longer than :func:`padlen` and ``sos[:, 3]`` all 1 (callers check). ``keep``:
    only these output samples are returned; ``zi``: ``sosfilt_zi(sos)`` if known;
    ``work``: a scratch array, reused if it fits (pass back what this returned).

    >>> from labjoint.signal.filter import butter_sos
    >>> sos = butter_sos(50_000.0)
    >>> x = np.random.default_rng(1).standard_normal((2, 50_000))
    >>> whole = sps.sosfiltfilt(sos, x, axis=-1)
    >>> bool(np.array_equal(filtfilt_pieces(sos, x)[0], whole))
    True
    >>> y, _ = filtfilt_pieces(sos, x, pieces=8, overlap=300)
    >>> bool(np.max(np.abs(y - whole)) < 1e-12 * np.max(np.abs(whole)))
    True
    """
    rows, n = x.shape
    lo, hi = keep if keep is not None else (0, n)
    pad = padlen(sos)
    joins = np.round(np.arange(pieces + 1) * (n / pieces)).astype(np.int64)
    width = min(int(np.max(np.diff(joins))) + 2 * overlap, n)
    starts = np.clip(joins[:-1] - overlap, 0, n - width)
    shape = (width + 2 * pad, rows * pieces)
    if work is None or work.shape[0] < shape[0] or work.shape[1] != shape[1]:
        work = np.empty(shape)
    sos = np.ascontiguousarray(sos, dtype=np.float64)
    zi = sps.sosfilt_zi(sos) if zi is None else zi
    out = np.empty((rows, hi - lo))
    _forward(sos, zi, np.ascontiguousarray(x, dtype=np.float64), starts, width, pad,
             work[:shape[0]])
    _backward(sos, zi, work[:shape[0]], starts, np.clip(joins, lo, hi), pad, lo, out)
    return out, work


@njit(cache=True, nogil=True, inline="always")
def _sections(sos, z0, z1, v):  # pragma: no cover - compiled
    """One sample through the cascaded sections, every lane (``v`` in, out)."""
    for s in range(sos.shape[0]):
        b0, b1, b2, a1, a2 = sos[s, 0], sos[s, 1], sos[s, 2], sos[s, 4], sos[s, 5]
        for q in range(v.size):
            y = b0 * v[q] + z0[s, q]
            z0[s, q] = b1 * v[q] - a1 * y + z1[s, q]
            z1[s, q] = b2 * v[q] - a2 * y
            v[q] = y


@njit(cache=True, nogil=True)
def _forward(sos, zi, x, starts, width, pad, lanes):  # pragma: no cover - compiled
    """Forward pass: lane ``r * pieces + p`` is row r from ``starts[p]``, ``width``
    samples, odd-extended by ``pad`` at both ends (scipy's ``odd_ext``); the filtered
    extended stretch is written to ``lanes`` (one row per sample)."""
    rows = x.shape[0]
    pieces = starts.size
    n_lanes = rows * pieces
    ns = sos.shape[0]
    z0 = np.empty((ns, n_lanes))
    z1 = np.empty((ns, n_lanes))
    v = np.empty(n_lanes)
    row = np.empty(n_lanes, dtype=np.int64)
    first = np.empty(n_lanes, dtype=np.int64)
    for r in range(rows):
        for p in range(pieces):
            row[r * pieces + p] = r
            first[r * pieces + p] = starts[p]
    for k in range(width + 2 * pad):
        if k < pad:
            for q in range(n_lanes):
                a = first[q]
                v[q] = 2.0 * x[row[q], a] - x[row[q], a + pad - k]
        elif k < pad + width:
            for q in range(n_lanes):
                v[q] = x[row[q], first[q] + k - pad]
        else:
            for q in range(n_lanes):
                last = first[q] + width - 1
                v[q] = 2.0 * x[row[q], last] - x[row[q], last - 1 - (k - pad - width)]
        if k == 0:
            for s in range(ns):
                for q in range(n_lanes):
                    z0[s, q] = zi[s, 0] * v[q]
                    z1[s, q] = zi[s, 1] * v[q]
        _sections(sos, z0, z1, v)
        for q in range(n_lanes):
            lanes[k, q] = v[q]


@njit(cache=True, nogil=True)
def _backward(sos, zi, lanes, starts, joins, pad, lo, out):  # pragma: no cover - compiled
    """Backward pass over ``lanes``; each lane's samples between its joins go to its
    row of ``out`` (which starts at sample ``lo``)."""
    n, n_lanes = lanes.shape
    ns = sos.shape[0]
    pieces = starts.size
    m = out.shape[1]
    flat = out.reshape(-1)
    z0 = np.empty((ns, n_lanes))
    z1 = np.empty((ns, n_lanes))
    v = np.empty(n_lanes)
    i_lo = np.empty(n_lanes, dtype=np.int64)        # lane q writes lanes[i] for i_lo <= i < i_hi
    i_hi = np.empty(n_lanes, dtype=np.int64)
    base = np.empty(n_lanes, dtype=np.int64)        # ... to flat[base + i]
    for q in range(n_lanes):
        p, r = q % pieces, q // pieces
        i_lo[q] = joins[p] - starts[p] + pad
        i_hi[q] = joins[p + 1] - starts[p] + pad
        base[q] = r * m + starts[p] - pad - lo
    for s in range(ns):
        for q in range(n_lanes):
            z0[s, q] = zi[s, 0] * lanes[n - 1, q]
            z1[s, q] = zi[s, 1] * lanes[n - 1, q]
    for k in range(n):
        i = n - 1 - k
        for q in range(n_lanes):
            v[q] = lanes[i, q]
        _sections(sos, z0, z1, v)
        for q in range(n_lanes):
            if i_lo[q] <= i < i_hi[q]:
                flat[base[q] + i] = v[q]
