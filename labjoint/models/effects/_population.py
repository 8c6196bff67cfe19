"""Parallel population of Jenkins elements (spring k_j in series with a slider), per sample.

The exact state model of every slider-based law (coulomb = one element; iwan and
richard_abbott = a discretised density, used when a modifier acts on them). Each element
carries its elastic force q_j in [-f_j s_-, f_j s_+]; a trial step q_j + k_j du outside
the interval slides to the bound and dissipates bound x slip. The strength scale is
s_+- = (1 +- asym) exp(-E_d / E_w), E_d the dissipation so far (own + ``e_other``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def population_force(u, k, f, k_el, asym, inv_ew, e_other):  # pragma: no cover - numba
    """Force and cumulative dissipation of elements (stiffness k_j N/m, slip force f_j N)
    in parallel with a spring k_el, relaxed at u[0]."""
    n = u.size
    m = k.size
    q = np.zeros(m)
    out = np.empty(n)
    ed_out = np.empty(n)
    ed = 0.0
    out[0] = 0.0
    ed_out[0] = 0.0
    for i in range(1, n):
        du = u[i] - u[i - 1]
        s = 1.0
        if inv_ew != 0.0:
            s = np.exp(-(ed + e_other[i - 1]) * inv_ew)
        sp = (1.0 + asym) * s
        sm = (1.0 - asym) * s
        tot = 0.0
        for j in range(m):
            qt = q[j] + k[j] * du
            hi = f[j] * sp
            lo = -f[j] * sm
            if qt > hi:
                ed += hi * (qt - hi) / k[j]
                qt = hi
            elif qt < lo:
                ed += -lo * (lo - qt) / k[j]
                qt = lo
            q[j] = qt
            tot += qt
        out[i] = tot + k_el * (u[i] - u[0])
        ed_out[i] = ed
    return out, ed_out


def _gauss2(m0: float, m1: float, m2: float, m3: float) -> tuple[np.ndarray, np.ndarray]:
    """Two-point Gauss rule (nodes, weights) from the first four moments of a weight."""
    # monic orthogonal p(t) = t^2 + c1 t + c0 with <p, 1> = <p, t> = 0
    det = m1 * m1 - m0 * m2
    c1 = (m0 * m3 - m1 * m2) / det
    c0 = (m2 * m2 - m1 * m3) / det
    disc = np.sqrt(max(c1 * c1 - 4 * c0, 0.0))
    t1, t2 = (-c1 - disc) / 2, (-c1 + disc) / 2
    w1 = (m1 - m0 * t2) / (t1 - t2)
    return np.array([t1, t2]), np.array([w1, m0 - w1])


def _power_moments(chi: float, q: float) -> list[float]:
    """int_q^1 t^(chi + k) dt, k = 0..3 (accurate for chi + 1 -> 0)."""
    out = []
    for kk in range(4):
        e = chi + kk + 1.0
        out.append(-np.expm1(e * np.log(q)) / e if q > 0 else 1.0 / e)
    return out


#: Iwan discretisation: geometric bins of ratio IWAN_Q on phi/phi_max in (IWAN_Q^N, 1]
#: (N = IWAN_BINS, lower edge ~1e-3), two Gauss sliders per bin (exact for the
#: dissipation of fully slipping bins; the bin holding the amplitude leaves an O(h^2)
#: error: < 7e-4 of the closed-form micro-slip energy for 1e-3 <= U/phi_max <= 1 and
#: -0.9 <= chi <= 0.9), two more for (0, IWAN_Q^N], plus the delta: 273 sliders.
IWAN_Q = 0.95
IWAN_BINS = 135


def iwan_population(F_S: float, K_T: float, chi: float, beta: float) -> tuple[np.ndarray, np.ndarray]:
    """Element stiffnesses (N/m) and slip forces (N) discretising Segalman's 4-parameter
    Iwan density rho(phi) = R phi^chi on (0, phi_max) plus S delta(phi - phi_max)
    (Segalman 2005, via seed 001). ``phi`` is each element's slip displacement."""
    d = beta + (chi + 1.0) / (chi + 2.0)
    phi_max = F_S * (1.0 + beta) / (K_T * d)
    r_phi = F_S * (chi + 1.0) / (phi_max * d)        # R phi_max^(chi + 1): stiffness scale
    s = (F_S / phi_max) * (beta / d)
    tn, tw = _gauss2(*_power_moments(chi, IWAN_Q))   # rule on [q, 1], weight t^chi
    bn, bw = _gauss2(*_power_moments(chi, 0.0))       # rule on [0, 1]
    tops = IWAN_Q ** np.arange(IWAN_BINS)            # bin upper edges / phi_max
    low = IWAN_Q ** IWAN_BINS
    x = np.concatenate([np.outer(tops, tn).ravel(), low * bn])
    w = np.concatenate([np.outer(tops ** (chi + 1.0), tw).ravel(), low ** (chi + 1.0) * bw])
    k = r_phi * w
    phi = x * phi_max
    k = np.append(k, s)
    phi = np.append(phi, phi_max)
    keep = k > 0
    return k[keep], (k * phi)[keep]


def backbone_population(density, edges: np.ndarray, nodes: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Two Gauss sliders per bin [edges[i], edges[i+1]] for a slip-displacement density
    ``density(phi)`` (stiffness per unit phi); bin moments by Gauss-Legendre in log phi."""
    gx, gw = np.polynomial.legendre.leggauss(nodes)
    a, b = edges[:-1], edges[1:]
    la, lb = np.log(a), np.log(b)
    s = 0.5 * (lb - la)[:, None] * gx[None, :] + 0.5 * (lb + la)[:, None]
    phi = np.exp(s)
    wq = 0.5 * (lb - la)[:, None] * gw[None, :] * phi * density(phi)  # d phi = phi d s
    t = phi / b[:, None]
    mom = [np.sum(wq * t ** kk, axis=1) for kk in range(4)]
    ks, fs = [], []
    for i in range(a.size):
        if mom[0][i] <= 0:
            continue
        tn, tw = _gauss2(mom[0][i], mom[1][i], mom[2][i], mom[3][i])
        ks.append(tw)
        fs.append(tw * tn * b[i])
    return np.concatenate(ks), np.concatenate(fs)
