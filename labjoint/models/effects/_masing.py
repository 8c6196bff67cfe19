"""Masing models with memory (extended Masing rules), exact and O(1) per sample.

A backbone g (odd, g(0) = 0) defines the whole hysteresis (Masing hypothesis, seed 001):

1. from the relaxed state the force follows the virgin curve F = g(u - u0);
2. after a reversal (u_r, F_r) it follows F = F_r + 2 g((u - u_r) / 2) (seed 000: the
   Richard-Abbott law with Masing unloading/reloading);
3. a branch that reaches the reversal point where the previous branch began closes that
   minor loop and continues on the branch that preceded it; a branch that reaches the
   largest excursion so far rejoins the virgin curve.

Rules 1-3 are exactly what a parallel Iwan population does (Iwan 1966), so with the
closed-form Segalman backbone this is an exact Iwan simulation. Reversal points are
kept on a stack (capacity ``STACK``; on overflow the oldest unclosed pair is forgotten).
"""

from __future__ import annotations

import numpy as np
from numba import njit

IWAN = 0
RICHARD_ABBOTT = 1
STACK = 4096


@njit(cache=True)
def backbone(kind, p, x):  # pragma: no cover - numba
    """Backbone g(x): kind IWAN p = (F_S, phi_max, D, beta, chi); kind RICHARD_ABBOTT
    p = (ke - kp, F_y, n, kp)."""
    ax = abs(x)
    sg = 1.0 if x >= 0.0 else -1.0
    if kind == IWAN:
        if ax >= p[1]:
            return sg * p[0]
        r = ax / p[1]
        # Segalman 4-parameter backbone: F = F_S/D [(1 + beta) r - r^(chi+2) / (chi+2)]
        return sg * p[0] / p[2] * ((1.0 + p[3]) * r - r ** (p[4] + 2.0) / (p[4] + 2.0))
    # Richard-Abbott, seed 000 Eq. 2: (ke-kp) u / (1 + |(ke-kp) u / F_y|^n)^(1/n) + kp u
    y = abs(p[0]) * ax
    r = y / p[1]
    if r <= 1.0:
        h = y / (1.0 + r ** p[2]) ** (1.0 / p[2])
    else:
        h = p[1] / (1.0 + r ** (-p[2])) ** (1.0 / p[2])
    if p[0] < 0.0:
        h = -h
    return sg * (h + p[3] * ax)


#: the Masing state carried between steps (:func:`masing_state`): reversal stack
#: ``hist`` (2, STACK) of (u_r, F_r), and ``st`` = (top, direction, u_prev, F_prev, u0)
M_TOP, M_DIR, M_PREV, M_FPREV, M_U0 = 0, 1, 2, 3, 4


def masing_state(u0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A relaxed Masing state at displacement ``u0``: (hist, st)."""
    return np.zeros((2, STACK)), np.array([0.0, 0.0, u0, 0.0, u0])


@njit(cache=True)
def masing_eval(kind, p, hist, st, x):  # pragma: no cover - numba
    """The force at ``x`` reached from the state's last point in one monotone move (an
    RK4 stage), the state left unchanged: rules 1-3 with the last point a reversal if
    the move turns back."""
    return _masing_move(kind, p, hist, st, x, False)


@njit(cache=True)
def masing_commit(kind, p, hist, st, x):  # pragma: no cover - numba
    """Move the state to ``x`` (the end of a step or a sample) and return the force."""
    return _masing_move(kind, p, hist, st, x, True)


@njit(cache=True)
def _masing_move(kind, p, hist, st, x, commit):  # pragma: no cover - numba
    prev, fprev = st[M_PREV], st[M_FPREV]
    step = x - prev
    if step == 0.0:
        return fprev
    top = int(st[M_TOP])
    d = int(st[M_DIR])
    nd = 1 if step > 0.0 else -1
    push = d != 0 and nd != d
    off = 0                         # hist[:, off:] is the stack
    if push and top == STACK:       # forget the oldest unclosed pair
        if commit:
            for j in range(2, STACK):
                hist[0, j - 2] = hist[0, j]
                hist[1, j - 2] = hist[1, j]
        else:
            off = 2                 # the stack the commit will see, without shifting it
        top -= 2
    # the stack seen from x: hist[:, :top] plus (prev, fprev) when the move turns back
    t = top + (1 if push else 0)
    u0 = st[M_U0]
    while t > 0:
        if t >= 2:
            ur2 = prev if (push and t - 2 == top) else hist[0, t - 2 + off]
            if nd * (x - ur2) >= 0.0:
                t -= 2
                continue
        else:
            ur0 = prev if (push and top == 0) else hist[0, off]
            if nd * (x - (2.0 * u0 - ur0)) >= 0.0:
                t = 0
                continue
        break
    if t == 0:
        f = backbone(kind, p, x - u0)
    else:
        if push and t - 1 == top:
            ur, frr = prev, fprev
        else:
            ur, frr = hist[0, t - 1 + off], hist[1, t - 1 + off]
        f = frr + 2.0 * backbone(kind, p, 0.5 * (x - ur))
    if commit:
        if push:
            hist[0, top] = prev
            hist[1, top] = fprev
        st[M_TOP] = t
        st[M_DIR] = nd
        st[M_PREV] = x
        st[M_FPREV] = f
    return f


@njit(cache=True)
def masing_force(u, kind, p):  # pragma: no cover - numba
    """Force along history ``u`` by the extended Masing rules, relaxed at u[0]."""
    n = u.size
    out = np.empty(n)
    hist = np.empty((2, STACK))
    st = np.array([0.0, 0.0, u[0], 0.0, u[0]])
    out[0] = 0.0
    for i in range(1, n):
        out[i] = masing_commit(kind, p, hist, st, u[i])
    return out


@njit(cache=True)
def running_work(u, f):  # pragma: no cover - numba
    """Running work int F du (trapezoid): equals the dissipated energy at closed cycles."""
    n = u.size
    out = np.empty(n)
    w = 0.0
    out[0] = 0.0
    for i in range(1, n):
        w += 0.5 * (f[i] + f[i - 1]) * (u[i] - u[i - 1])
        out[i] = w
    return out


def iwan_params(F_S: float, K_T: float, chi: float, beta: float) -> np.ndarray:
    """Backbone parameter vector of the Segalman Iwan model (see :func:`backbone`)."""
    d = max(beta + (chi + 1.0) / (chi + 2.0), 1e-300)
    phi_max = F_S * (1.0 + beta) / (K_T * d)
    return np.array([F_S, phi_max, d, beta, chi])


def ra_params(ke: float, kp: float, F_y: float, n: float) -> np.ndarray:
    """Backbone parameter vector of the Richard-Abbott law (see :func:`backbone`)."""
    return np.array([ke - kp, F_y, n, kp])
