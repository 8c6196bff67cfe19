"""FRFs of one block with its transients removed: the local rational method (LRM).

The DFT of a block cut from a longer response, rectangular and unwindowed, is not
Y = H U: the states at the block's start and end add a transient term T (the leakage of
a lightly damped mode), a smooth rational function of frequency with the system's own
poles. Around each line k a local rational model in the line offset r = -R..R holds both
(McKelvey & Guérin, "Non-parametric frequency response estimation using a local rational
model", IFAC SYSID 2012; Pintelon & Schoukens, *System Identification*, 2nd ed., Sec. 7.2,
the transient term of Eq. 6-23):

    Y(k + r) = N_k(r) / D_k(r) U(k + r) + M_k(r) / D_k(r) + V(k + r),
    D_k(r) = 1 + d_1 r + ... + d_q r^q,  N_k, M_k polynomials of degree q,

linear in the coefficients once multiplied by D_k (Levy); H(k) = N_k(0). A rational local
model follows a resonance narrower than the line spacing, where a local polynomial
(the LPM) cannot. The noise variance comes from the residuals (2R + 1 equations less the
3q + 2 coefficients), the variance of H(k) from the covariance of the least squares.

A burst's driven part through LRM is the FRF at the burst's own amplitude: the free
decay after the drive stops, where a nonlinear joint rings at lower amplitude (a
softening joint at a higher frequency, with less damping), is not mixed into it.

>>> fs, n = 256.0, 4096
>>> u = np.random.default_rng(0).normal(size=n)
>>> y = np.convolve(u, [0.5, 0.3], "full")[:n]      # y starts mid-stream: a transient
>>> U, Y = np.fft.rfft(u), np.fft.rfft(y)[None]
>>> h, std = local_rational(U, Y)
>>> want = 0.5 + 0.3 * np.exp(-2j * np.pi * np.arange(U.size) / n)
>>> bool(np.max(np.abs(h[0, 1:] - want[1:])) < 1e-6)
True
"""

from __future__ import annotations

from typing import Any

import numpy as np

from labjoint.errors import InputError

#: lines each side of the local window, and the degree of the local polynomials
HALF_WIDTH, DEGREE = 7, 2
#: lines fitted at once (the local systems of a chunk: CHUNK_LINES x (2R + 1) x (3q + 2))
CHUNK_LINES = 1 << 14


def local_rational(U: Any, Y: Any, half_width: int = HALF_WIDTH,
                   degree: int = DEGREE) -> tuple[np.ndarray, np.ndarray]:
    """(H, std): the FRF of responses' spectra ``Y`` (S, n) over the drive's ``U`` (n,) at
    every line, and the std of each of its components (re, im). Near the ends the window
    is shifted to stay inside the lines (module docstring)."""
    U = np.asarray(U, complex)
    Y = np.atleast_2d(np.asarray(Y, complex))
    q, R = int(degree), int(half_width)
    width = 2 * R + 1
    p = 3 * q + 2
    if U.size < width or width <= p:
        raise InputError(f"the local rational method needs more than {max(width, p)} lines, "
                         f"got {U.size}", field="drive")
    n = U.size
    h = np.empty(Y.shape, complex)
    std = np.empty(Y.shape)
    for c0 in range(0, n, CHUNK_LINES):                        # bounded temporaries
        k = np.arange(c0, min(n, c0 + CHUNK_LINES))
        h[:, k], std[:, k] = _fit(U, Y, k, R, q)
    return h, std


def _fit(U: np.ndarray, Y: np.ndarray, k: np.ndarray, R: int, q: int) -> tuple[np.ndarray, np.ndarray]:
    """The local rational fits at lines ``k`` (:func:`local_rational`)."""
    n, width, p = U.size, 2 * R + 1, 3 * q + 2
    start = np.clip(k - R, 0, n - width)                      # each line's window
    idx = start[:, None] + np.arange(width)[None, :]          # (m, width)
    r = (idx - k[:, None]).astype(float) / R                  # scaled offsets: conditioning
    powers = r[:, :, None] ** np.arange(q + 1)[None, None, :]  # (m, width, q + 1)
    u = U[idx][:, :, None]
    m = k.size
    h = np.empty((Y.shape[0], m), complex)
    std = np.empty((Y.shape[0], m))
    e0 = np.zeros((m, p, 1), complex)
    e0[:, 0, 0] = 1.0
    for s in range(Y.shape[0]):
        y = Y[s, idx]                                          # (m, width)
        A = np.concatenate([powers * u, powers, -powers[:, :, 1:] * y[:, :, None]], axis=2)
        scale = np.linalg.norm(A, axis=1, keepdims=True)      # column scaling
        scale[scale == 0] = 1.0
        A /= scale
        Q, Rm = np.linalg.qr(A)
        theta = np.linalg.solve(Rm, np.einsum("nwp,nw->np", Q.conj(), y)[:, :, None])[:, :, 0]
        res = y - np.einsum("nwp,np->nw", A, theta)
        sigma2 = np.sum(np.abs(res) ** 2, axis=1) / (width - p)
        # var(theta_0) = sigma^2 [(A^H A)^-1]_00 = sigma^2 |row 0 of R^-1|^2, and that row
        # is the solution of R^H x = e_0 (conjugated)
        row = np.linalg.solve(np.conj(np.swapaxes(Rm, 1, 2)), e0)[:, :, 0]
        var0 = sigma2 * np.sum(np.abs(row) ** 2, axis=1)
        h[s] = theta[:, 0] / scale[:, 0, 0]
        std[s] = np.sqrt(var0 / 2.0) / scale[:, 0, 0]
    return h, std
