"""What a ringdown window's estimate actually achieves: its scatter about its neighbours.

A window's least-squares sd (:mod:`labjoint.signal.ringdown`) counts only the residuals
inside the window. Errors that are smooth within one window (a weak other tone beating
with the mode, the band-pass's leak, the force ratio's ripple in the force removal, noise
that the band-pass has made coloured) leave small residuals and move the whole window's
slope: on the simulated structural rig one window's sd was 3-6x below its neighbours'
and the window 36 sd off the hidden law.

The backbone is smooth in amplitude, and the windows follow each other in time (one
amplitude per window), so a window's error shows as its distance from a smooth local
trend of its neighbours. For window i: a polynomial of degree <= 2 in the window index
is fitted by least squares to the (up to) ``HALF`` windows on each side, i excluded; its
prediction at i leaves r_i, whose variance is s^2 (1 + h_i) for windows of independent
errors of sd s (h_i = x_i' (X'X)^-1 x_i, the prediction's leverage), so
e_i = r_i / sqrt(1 + h_i) estimates the error of one window. The stated sd of window i
is the larger of its least-squares sd and the rms of e_j over j within ``HALF`` of i
(the scatter is local: the noise's share grows as the decay falls towards it).

Checked (tests/test_ringdown_scatter.py) on an independent generator: a synthetic decay
with a known amplitude-dependent frequency and damping, white noise plus a weak detuned
tone, where the least-squares sd alone understates the frequency's error several times
and the stated sd gives |error| / sd an rms near 1.
"""

from __future__ import annotations

import numpy as np

#: windows on each side of a window that make its local trend and its local scatter
HALF = 3
#: the local trend's polynomial degree (at most; fewer neighbours lower it)
DEGREE = 2


def trend_residuals(values) -> np.ndarray:
    """e_i: each value's leave-one-out residual from its neighbours' local polynomial,
    scaled to one value's error (module docstring); nan where fewer than 2 neighbours."""
    v = np.asarray(values, dtype=float)
    n = v.size
    e = np.full(n, np.nan)
    for i in range(n):
        j = np.array([k for k in range(max(0, i - HALF), min(n, i + HALF + 1)) if k != i])
        if j.size < 2:
            continue
        deg = min(DEGREE, j.size - 1)
        X = np.vander((j - i).astype(float), deg + 1, increasing=True)
        coef, *_ = np.linalg.lstsq(X, v[j], rcond=None)
        XtX_inv = np.linalg.pinv(X.T @ X)
        h = float(XtX_inv[0, 0])               # x_i = (1, 0, 0) at the window itself
        e[i] = (v[i] - coef[0]) / np.sqrt(1.0 + h)
    return e


def local_scatter(values) -> np.ndarray:
    """Per value, the rms of the trend residuals within ``HALF`` of it (nan where none)."""
    e = trend_residuals(values)
    n = e.size
    out = np.full(n, np.nan)
    for i in range(n):
        w = e[max(0, i - HALF):min(n, i + HALF + 1)]
        w = w[np.isfinite(w)]
        if w.size:
            out[i] = float(np.sqrt(np.mean(w * w)))
    return out


def honest_sds(values, sds) -> np.ndarray:
    """The larger of each window's own sd and its local scatter (module docstring)."""
    s = np.asarray(sds, dtype=float)
    sc = local_scatter(values)
    return np.where(np.isfinite(sc), np.maximum(s, sc), s)
