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


@njit(cache=True)
def masing_force(u, kind, p):  # pragma: no cover - numba
    """Force along history ``u`` by the extended Masing rules, relaxed at u[0]."""
    n = u.size
    out = np.empty(n)
    ur = np.empty(STACK)
    fr = np.empty(STACK)
    top = 0
    u0 = u[0]
    d = 0
    prev = u0
    fprev = 0.0
    out[0] = 0.0
    for i in range(1, n):
        x = u[i]
        step = x - prev
        if step == 0.0:
            out[i] = fprev
            continue
        nd = 1 if step > 0.0 else -1
        if d != 0 and nd != d:
            if top == STACK:  # forget the oldest unclosed pair
                for j in range(2, STACK):
                    ur[j - 2] = ur[j]
                    fr[j - 2] = fr[j]
                top -= 2
            ur[top] = prev
            fr[top] = fprev
            top += 1
        d = nd
        while top > 0:
            if top >= 2:
                if d * (x - ur[top - 2]) >= 0.0:
                    top -= 2
                    continue
            elif d * (x - (2.0 * u0 - ur[0])) >= 0.0:
                top = 0
                continue
            break
        if top == 0:
            f = backbone(kind, p, x - u0)
        else:
            f = fr[top - 1] + 2.0 * backbone(kind, p, 0.5 * (x - ur[top - 1]))
        out[i] = f
        prev = x
        fprev = f
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
