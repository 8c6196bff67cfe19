"""The structural rig's continuous Iwan thread law: Segalman's density without its Dirac
term, simulated exactly by Masing's rules with memory on its closed-form backbone.

A parallel population of Jenkins elements of stiffness density rho(phi) = R phi^chi on
(0, phi_max) (seed 001: Segalman's 4-parameter Iwan, beta = 0) has the virgin curve
(hysteretic part, k_h = int rho the stiffness, F_S = int rho phi the macro-slip force)

    g(u) = F_S / D [r - r^(chi+2) / (chi+2)],  r = |u| / phi_max <= 1;  F_S beyond,
    D = (chi+1)/(chi+2),  phi_max = F_S / (D k_h),

and obeys Masing's rules with memory exactly (Iwan 1966): after a reversal (u_r, F_r) the
force is F_r + 2 g((u - u_r)/2); a branch that reaches the reversal point where the
previous branch began closes that minor loop and continues on the branch before it; the
branch from the first reversal u_1 rejoins the virgin curve at -u_1. One cycle of
amplitude U <= phi_max dissipates 4 R U^(chi+3) / ((chi+2)(chi+3)).

This is the simulator's own code (the truth the models are compared with), written
apart from labjoint.models; tests/test_sim_structure_iwan.py checks it against a fine
population of sliders written in the test and against the closed forms above.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: reversal points kept per thread; on overflow the oldest pair is forgotten
STACK = 1024
#: state columns: number of reversals on the stack, direction, u and F of the last step
TOP, DIR, U_PREV, F_PREV = range(4)
N_STATE = 4


def iwan_parameters(k_h: float, slip_force: float, chi: float) -> np.ndarray:
    """(F_S, phi_max, D, chi) of the backbone for stiffness ``k_h`` (N/m), macro-slip
    force ``slip_force`` (N) and density exponent ``chi``."""
    d = (chi + 1.0) / (chi + 2.0)
    return np.array([slip_force, slip_force / (d * k_h), d, chi])


def iwan_state(n_joints: int) -> tuple[np.ndarray, np.ndarray]:
    """A virgin state for ``n_joints`` threads: (st (n, N_STATE), hist (n, 2, STACK))."""
    return np.zeros((n_joints, N_STATE)), np.zeros((n_joints, 2, STACK))


@njit(cache=True, inline="always")
def iwan_backbone(x, p):
    """Virgin curve g(x) of the hysteretic part (p from :func:`iwan_parameters`)."""
    ax = abs(x)
    f = p[0]
    if ax < p[1]:
        r = ax / p[1]
        rc = r * r if p[3] == 0.0 else r ** (p[3] + 2.0)      # chi = 0 without a pow
        f = p[0] / p[2] * (r - rc / (p[3] + 2.0))
    return f if x >= 0.0 else -f


@njit(cache=True, inline="always")
def iwan_step(u, p, st, hist, j):
    """Force of thread ``j``'s hysteretic part at slip ``u`` after its state's last point;
    the state (``st``, ``hist`` of :func:`iwan_state`) moves to ``u``.

    >>> p = iwan_parameters(1e8, 1e3, 0.0); st, h = iwan_state(1)
    >>> f = [iwan_step(u, p, st, h, 0) for u in (5e-6, -5e-6, 5e-6)]
    >>> abs(f[2] - f[0]) < 1e-9 * f[0], int(st[0, 0])      # the loop closes on the virgin curve
    (True, 0)
    """
    du = u - st[j, U_PREV]
    if du == 0.0:
        return st[j, F_PREV]
    d = 1.0 if du > 0.0 else -1.0
    n = int(st[j, TOP])
    if st[j, DIR] != 0.0 and d != st[j, DIR]:
        if n == STACK:                       # forget the oldest pair
            for i in range(STACK - 2):
                hist[j, 0, i] = hist[j, 0, i + 2]
                hist[j, 1, i] = hist[j, 1, i + 2]
            n -= 2
        hist[j, 0, n] = st[j, U_PREV]
        hist[j, 1, n] = st[j, F_PREV]
        n += 1
    st[j, DIR] = d
    while n > 0:
        # the point that closes the current branch: the reversal before it, or for the
        # first reversal its mirror on the virgin curve
        end = hist[j, 0, n - 2] if n >= 2 else -hist[j, 0, 0]
        if (u - end) * d < 0.0:
            break
        n -= 2 if n >= 2 else 1
    if n == 0:
        f = iwan_backbone(u, p)
    else:
        f = hist[j, 1, n - 1] + 2.0 * iwan_backbone(0.5 * (u - hist[j, 0, n - 1]), p)
    st[j, TOP] = n
    st[j, U_PREV] = u
    st[j, F_PREV] = f
    return f
