"""Zero-phase IIR filtering with independent filter chains side by side in SIMD lanes.

The recursion of one chain of second-order sections cannot be vectorised, but the same
operations on independent chains can: rows, and pieces of a long row, are interleaved
sample by sample ("lanes"), so each section step of all lanes is a few vector
instructions. Each lane is exactly scipy's ``sosfiltfilt`` of its stretch (odd
extension, ``sosfilt_zi`` initial states, direct form II transposed): a whole row in one
lane is filtered bit for bit as scipy does it. The stretches are copied into the lanes,
filtered there in place forward and backward (three sections at a time, written out), and
copied back out.
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
    zi = sps.sosfilt_zi(sos) if zi is None else zi
    groups, zis = _groups(np.ascontiguousarray(sos, dtype=np.float64), zi)
    out = np.empty((rows, hi - lo))
    lanes = work[:shape[0]]
    _extend(np.ascontiguousarray(x, dtype=np.float64), starts, width, pad, lanes)
    first = lanes[0].copy()
    for g in range(groups.shape[0]):                 # forward, in place
        _three(groups[g], zis[g], first, lanes, False)
    last = lanes[-1].copy()
    for g in range(groups.shape[0]):                 # backward, in place
        _three(groups[g], zis[g], last, lanes, True)
    _collect(lanes, starts, np.clip(joins, lo, hi), pad, lo, out)
    return out, work


def _groups(sos: np.ndarray, zi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The sections (and their ``sosfilt_zi`` rows) in groups of three, the last group
    completed with identity sections (``y = v``, zero state) that leave every value as
    it is."""
    ns = sos.shape[0]
    n_groups = -(-ns // 3)
    groups = np.zeros((n_groups * 3, 6))
    groups[:, 0] = groups[:, 3] = 1.0
    groups[:ns] = sos
    zis = np.zeros((n_groups * 3, 2))
    zis[:ns] = zi
    return groups.reshape(n_groups, 3, 6), zis.reshape(n_groups, 3, 2)


@njit(cache=True, nogil=True)
def _extend(x, starts, width, pad, lanes):  # pragma: no cover - compiled
    """Lane ``r * pieces + p`` of ``lanes`` (one row per sample) = row r of ``x`` from
    ``starts[p]``, ``width`` samples, odd-extended by ``pad`` at both ends (scipy's
    ``odd_ext``). Filled a row of ``lanes`` at a time (written once, in order)."""
    rows = x.shape[0]
    pieces = starts.size
    for r in range(rows):
        for p in range(pieces):
            q = r * pieces + p
            a = starts[p]
            last = a + width - 1
            for k in range(pad):
                lanes[k, q] = 2.0 * x[r, a] - x[r, a + pad - k]
                lanes[pad + width + k, q] = 2.0 * x[r, last] - x[r, last - 1 - k]
    for k in range(width):
        for r in range(rows):
            for p in range(pieces):
                lanes[pad + k, r * pieces + p] = x[r, starts[p] + k]


@njit(cache=True, nogil=True)
def _three(sos, zi, x0, lanes, backward):  # pragma: no cover - compiled
    """Three cascaded sections (direct form II transposed, as scipy's ``sosfilt``) run
    over every lane of ``lanes`` in place, forward or ``backward`` in time; each
    section's state starts at ``zi * x0`` of its lane (``sosfiltfilt``'s initial
    conditions, ``x0`` the lane's first input sample in that direction).

    The three sections are written out so that each sample of all lanes is a few
    vector instructions with the twelve states of a lane in registers (a loop over the
    sections kept them in memory, 3x slower); the operations are scipy's, in its order.
    """
    n, nl = lanes.shape
    b00, b01, b02, a01, a02 = sos[0, 0], sos[0, 1], sos[0, 2], sos[0, 4], sos[0, 5]
    b10, b11, b12, a11, a12 = sos[1, 0], sos[1, 1], sos[1, 2], sos[1, 4], sos[1, 5]
    b20, b21, b22, a21, a22 = sos[2, 0], sos[2, 1], sos[2, 2], sos[2, 4], sos[2, 5]
    p0 = np.empty(nl)
    p1 = np.empty(nl)
    q0 = np.empty(nl)
    q1 = np.empty(nl)
    r0 = np.empty(nl)
    r1 = np.empty(nl)
    for j in range(nl):
        p0[j] = zi[0, 0] * x0[j]
        p1[j] = zi[0, 1] * x0[j]
        q0[j] = zi[1, 0] * x0[j]
        q1[j] = zi[1, 1] * x0[j]
        r0[j] = zi[2, 0] * x0[j]
        r1[j] = zi[2, 1] * x0[j]
    for kk in range(n):
        k = n - 1 - kk if backward else kk
        for j in range(nl):
            v = lanes[k, j]
            y = b00 * v + p0[j]
            p0[j] = b01 * v - a01 * y + p1[j]
            p1[j] = b02 * v - a02 * y
            v = y
            y = b10 * v + q0[j]
            q0[j] = b11 * v - a11 * y + q1[j]
            q1[j] = b12 * v - a12 * y
            v = y
            y = b20 * v + r0[j]
            r0[j] = b21 * v - a21 * y + r1[j]
            r1[j] = b22 * v - a22 * y
            lanes[k, j] = y


@njit(cache=True, nogil=True)
def _collect(lanes, starts, joins, pad, lo, out):  # pragma: no cover - compiled
    """Each lane's samples between its joins (clipped to the kept range) to its row of
    ``out``, which starts at sample ``lo``; a row of ``lanes`` at a time (read once,
    in order)."""
    pieces = starts.size
    n_lanes = lanes.shape[1]
    m = out.shape[1]
    flat = out.reshape(-1)
    i_lo = np.empty(n_lanes, dtype=np.int64)        # lane q gives lanes[i] for i_lo <= i < i_hi
    i_hi = np.empty(n_lanes, dtype=np.int64)
    base = np.empty(n_lanes, dtype=np.int64)        # ... to flat[base + i]
    for q in range(n_lanes):
        p, r = q % pieces, q // pieces
        i_lo[q] = joins[p] - starts[p] + pad
        i_hi[q] = joins[p + 1] - starts[p] + pad
        base[q] = r * m + starts[p] - pad - lo
    for i in range(min(i_lo.min(), lanes.shape[0]), min(i_hi.max(), lanes.shape[0])):
        for q in range(n_lanes):
            if i_lo[q] <= i < i_hi[q]:
                flat[base[q] + i] = lanes[i, q]
