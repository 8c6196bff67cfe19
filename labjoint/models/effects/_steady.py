"""Steady periodic force of slider and Masing laws for a whole batch of periods in one call.

The structure's harmonic balance (AFT, :meth:`labjoint.structure.law.JointLaw.periodic`)
needs the steady force over one period for many histories at once (every patch of every
joint, and the perturbed copies of its finite-difference Jacobian). Each row is run as
the law's own history is: relaxed at u = 0, then ``prime`` copies of the period rotated to
start at its largest value, the last copy being the steady one. Each term calls the same
kernel its effect's ``simulate`` calls (:func:`masing_force`, :func:`population_force`),
so the forces are the same numbers; only the per-row Python calls are gone (they had
cost far more than the laws: issue 32 item 6).

A term is (code, parameter vector) as :meth:`HystereticEffect.steady_term` gives it:
``MASING_IWAN`` / ``MASING_RA`` (the backbone's vector, :mod:`._masing`), ``JENKINS``
(k, f_s: one element of :func:`population_force`), ``LINEAR`` (k: k (u - u[0])),
``NONE`` (no force), and the memoryless force terms (``U_LINEAR`` ... ``CONTACT``: force
and elastic effects, evaluated on the period's samples of u, v, a; ``SATURATING``:
k_s x_s tanh(u / x_s)).

:func:`steady_tangent` gives the same forces and their exact derivatives with respect to
the coefficients c of each row's period (the row's samples being u = s_r T c): forward
mode through the same rules (the backbone's slope on each branch, the reversal points'
own derivatives carried on the stack), so harmonic balance's Jacobian costs about one
evaluation instead of one per coefficient.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from labjoint.models.effects._masing import IWAN, RICHARD_ABBOTT, STACK, backbone, masing_force
from labjoint.models.effects._population import population_force

MASING_IWAN = IWAN
MASING_RA = RICHARD_ABBOTT
JENKINS = 10
LINEAR = 11
NONE = 12
#: memoryless terms p0 x f(sample): p0 u, p0 v, p0 a, p0 u^3, p0, p0 u^2, p0 max(u, 0),
#: a contact p0 max(p1 u - p2, 0) (p1 = sgn p0) and a saturating p0 p1 tanh(u / p1)
U_LINEAR, V_LINEAR, A_LINEAR, U_CUBE, CONST, U_SQUARE, U_RAMP, CONTACT, SATURATING = range(20, 29)
#: width of a term's parameter vector (the longest backbone vector)
WIDTH = 5


@njit(cache=True)
def memoryless(c, p, u, v, a):  # pragma: no cover - numba
    """Force of a memoryless term at one sample and its partial derivatives in u, v, a."""
    if c == U_LINEAR:
        return p[0] * u, p[0], 0.0, 0.0
    if c == V_LINEAR:
        return p[0] * v, 0.0, p[0], 0.0
    if c == A_LINEAR:
        return p[0] * a, 0.0, 0.0, p[0]
    if c == U_CUBE:
        return p[0] * u ** 3, 3.0 * p[0] * u * u, 0.0, 0.0
    if c == CONST:
        return p[0], 0.0, 0.0, 0.0
    if c == U_SQUARE:
        return p[0] * u ** 2, 2.0 * p[0] * u, 0.0, 0.0
    if c == U_RAMP:
        return p[0] * max(u, 0.0), (p[0] if u > 0.0 else 0.0), 0.0, 0.0
    if c == SATURATING:
        if not p[1] > 0.0:
            return 0.0, 0.0, 0.0, 0.0
        th = np.tanh(u / p[1])
        return p[0] * p[1] * th, p[0] * (1.0 - th * th), 0.0, 0.0
    x = p[1] * u - p[2]
    return p[0] * max(x, 0.0), (p[0] * p[1] if x > 0.0 else 0.0), 0.0, 0.0


@njit(cache=True)
def steady_batch(u, v, a, codes, P, prime):  # pragma: no cover - numba
    """(rows, n) steady force of the sum of the terms (``codes``, rows of ``P``) along each
    row of ``u`` (one period, n samples; rates ``v``, ``a``) after the priming described in
    the module."""
    rows, n = u.shape
    out = np.zeros((rows, n))
    m = 1 + prime * n
    hist = np.empty(m)
    zeros = np.zeros(m)
    kj = np.empty(1)
    fj = np.empty(1)
    start = 1 + (prime - 1) * n
    for r in range(rows):
        i0 = 0
        for j in range(1, n):
            if u[r, j] > u[r, i0]:
                i0 = j
        hist[0] = 0.0
        for p in range(prime):
            for j in range(n):
                hist[1 + p * n + j] = u[r, (j + i0) % n]
        tot = np.zeros(n)
        for t in range(codes.size):
            c = codes[t]
            if c == NONE:
                continue
            if c >= U_LINEAR:
                for j in range(n):
                    jj = (j + i0) % n
                    tot[j] += memoryless(c, P[t], u[r, jj], v[r, jj], a[r, jj])[0]
                continue
            if c == LINEAR:
                for j in range(n):
                    tot[j] += P[t, 0] * (hist[start + j] - hist[0])
                continue
            if c == JENKINS:
                kj[0] = P[t, 0]
                fj[0] = P[t, 1]
                f = population_force(hist, kj, fj, 0.0, 0.0, 0.0, zeros)[0]
            else:
                f = masing_force(hist, c, P[t])
            for j in range(n):
                tot[j] += f[start + j]
        for j in range(n):
            out[r, (j + i0) % n] = tot[j]
    return out


@njit(cache=True)
def dbackbone(kind, p, x):  # pragma: no cover - numba
    """Slope g'(x) of :func:`labjoint.models.effects._masing.backbone` (an even function)."""
    ax = abs(x)
    if kind == IWAN:
        if ax >= p[1]:
            return 0.0
        r = ax / p[1]
        return p[0] / (p[2] * p[1]) * ((1.0 + p[3]) - r ** (p[4] + 1.0))
    r = abs(p[0]) * ax / p[1]
    if r <= 1.0:
        dh = (1.0 + r ** p[2]) ** (-1.0 / p[2] - 1.0)
    else:
        dh = r ** (-p[2] - 1.0) * (1.0 + r ** (-p[2])) ** (-1.0 / p[2] - 1.0)
    return p[0] * dh + p[3]


@njit(cache=True)
def masing_tangent(u, du, kind, p, f, df):  # pragma: no cover - numba
    """:func:`masing_force` along ``u`` into ``f`` and its derivative into ``df`` (len, m),
    ``du`` (len, m) the derivative of ``u``: the same rules, step by step."""
    n = u.size
    m = du.shape[1]
    cap = min(STACK, n + 2)
    ur = np.empty(cap)
    fr = np.empty(cap)
    dur = np.empty((cap, m))
    dfr = np.empty((cap, m))
    top = 0
    u0 = u[0]
    d = 0
    prev = u0
    fprev = 0.0
    iprev = 0
    f[0] = 0.0
    df[0, :] = 0.0
    for i in range(1, n):
        x = u[i]
        step = x - prev
        if step == 0.0:
            f[i] = fprev
            df[i, :] = df[i - 1, :]
            continue
        nd = 1 if step > 0.0 else -1
        if d != 0 and nd != d:
            if top == cap:
                for j in range(2, cap):
                    ur[j - 2] = ur[j]
                    fr[j - 2] = fr[j]
                    dur[j - 2, :] = dur[j, :]
                    dfr[j - 2, :] = dfr[j, :]
                top -= 2
            ur[top] = prev
            fr[top] = fprev
            dur[top, :] = du[iprev, :]
            dfr[top, :] = df[i - 1, :]
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
            fi = backbone(kind, p, x - u0)
            s = dbackbone(kind, p, x - u0)
            for k in range(m):
                df[i, k] = s * (du[i, k] - du[0, k])
        else:
            xr = 0.5 * (x - ur[top - 1])
            fi = fr[top - 1] + 2.0 * backbone(kind, p, xr)
            s = dbackbone(kind, p, xr)
            for k in range(m):
                df[i, k] = dfr[top - 1, k] + s * (du[i, k] - dur[top - 1, k])
        f[i] = fi
        prev = x
        iprev = i
        fprev = fi
    return f, df


@njit(cache=True)
def steady_tangent(u, v, a, s, T, Tv, Ta, codes, P, prime):  # pragma: no cover - numba
    """:func:`steady_batch` and its derivative (rows, n, m) in each row's coefficients c,
    row r's samples being u[r] = s[r] T c, v[r] = s[r] Tv c, a[r] = s[r] Ta c (T: (n, m))."""
    rows, n = u.shape
    m = T.shape[1]
    out = np.zeros((rows, n))
    dout = np.zeros((rows, n, m))
    L = 1 + prime * n
    hist = np.empty(L)
    dhist = np.empty((L, m))
    f = np.empty(L)
    df = np.empty((L, m))
    start = 1 + (prime - 1) * n
    for r in range(rows):
        i0 = 0
        for j in range(1, n):
            if u[r, j] > u[r, i0]:
                i0 = j
        hist[0] = 0.0
        dhist[0, :] = 0.0
        for p in range(prime):
            for j in range(n):
                jj = (j + i0) % n
                hist[1 + p * n + j] = u[r, jj]
                for k in range(m):
                    dhist[1 + p * n + j, k] = s[r] * T[jj, k]
        for t in range(codes.size):
            c = codes[t]
            if c == NONE:
                continue
            if c >= U_LINEAR:
                for j in range(n):
                    fu, du, dv, da = memoryless(c, P[t], u[r, j], v[r, j], a[r, j])
                    out[r, j] += fu
                    for k in range(m):
                        dout[r, j, k] += s[r] * (du * T[j, k] + dv * Tv[j, k] + da * Ta[j, k])
                continue
            if c == LINEAR:
                for j in range(n):
                    jj = (j + i0) % n
                    out[r, jj] += P[t, 0] * (hist[start + j] - hist[0])
                    for k in range(m):
                        dout[r, jj, k] += P[t, 0] * dhist[start + j, k]
                continue
            if c == JENKINS:
                jenkins_tangent(hist, dhist, P[t, 0], P[t, 1], f, df)
            else:
                masing_tangent(hist, dhist, c, P[t], f, df)
            for j in range(n):
                jj = (j + i0) % n
                out[r, jj] += f[start + j]
                for k in range(m):
                    dout[r, jj, k] += df[start + j, k]
    return out, dout


@njit(cache=True)
def jenkins_tangent(u, du, k, fs, f, df):  # pragma: no cover - numba
    """One element of :func:`population_force` (no modifiers) into ``f`` and its
    derivative into ``df``: the elastic force follows k du while it sticks, and is held
    at the bound (derivative zero) while it slides."""
    m = du.shape[1]
    q = 0.0
    f[0] = 0.0
    df[0, :] = 0.0
    for i in range(1, u.size):
        qt = q + k * (u[i] - u[i - 1])
        if qt > fs:
            qt = fs
            df[i, :] = 0.0
        elif qt < -fs:
            qt = -fs
            df[i, :] = 0.0
        else:
            for j in range(m):
                df[i, j] = df[i - 1, j] + k * (du[i, j] - du[i - 1, j])
        q = qt
        f[i] = qt
    return f, df


def term_matrix(terms: list[tuple[int, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Codes and the (terms, ``WIDTH``) parameter matrix of a list of terms."""
    codes = np.array([c for c, _ in terms], np.int64)
    P = np.zeros((len(terms), WIDTH))
    for i, (_, p) in enumerate(terms):
        P[i, :len(p)] = p
    return codes, P
