"""The model's phase-resonance point: the single-point force at the excitation DOF for which
the response at the sensor is in quadrature with it at a given amplitude; the
measurement's own definition (:func:`labjoint.identify.backbone.phase_resonance_backbone`)
on the model's side.

Why beside the EPMC: the EPMC (Krack 2015) balances the joints' dissipation with a
mass-proportional negative damping spread over the whole structure, a phase-resonance
test with one force at one point. The other modes then answer that force off resonance,
and the quadrature at the sensor moves: on the simulated rig's seed-000 assembly with its
hidden Iwan, the forced quadrature at 3.1e-3 m sits 0.00022 Hz (8e-6, about 20 of the
measured point's standard uncertainties) below the EPMC's frequency, 0.00003 Hz at
9.8e-4 m (the shift grows with the damping). Compared with a phase-resonance point, the
model's must be this one.

Unknowns (X, w, F): the harmonic balance (:class:`~labjoint.structure.hbm.HarmonicBalance`)
with the force -F sin(w t) at the excitation DOF, so that quadrature (the displacement
lagging the force by 90 deg) puts the sensor's fundamental in cos(w t), as the EPMC's
phase condition does:

    R(X, w) + F g = 0,    r . X_s1 = 0,    r . X_c1 = a,

g the excitation vector in the sine-1 rows, r the sensor's row. Newton from the EPMC's
solution at the same amplitude (its force F_0 the projection of its xi M x' on g). The
damping ratio then follows from the measurement's force balance, zeta = F / (2 m w^2 a),
with the model's apparent modal mass m = phi^T M phi / (phi_d phi_s) of its nonlinear mode
at that amplitude (phi the EPMC's fundamental; the measurement's m_eff is its estimate of
the same, and a structure model's mass distribution is not the joint's to fit).
"""

from __future__ import annotations

import numpy as np

from labjoint.structure.epmc import EPMC
from labjoint.structure.hbm import ConvergenceError, lu_factor, lu_solve

#: Newton on the forced quadrature: iterations and relative tolerance
NEWTON_MAX = 30
TOL = 1e-10


def forced_quadrature(ep: EPMC, a: float, y_epmc: np.ndarray) -> tuple[float, float]:
    """(w rad/s, F N) of the forced phase resonance at amplitude ``a`` (m at ``ep``'s
    output), from the EPMC's solution ``y_epmc`` = (X, w, xi) at that amplitude."""
    hb, n, size = ep.hb, ep.n, ep._size
    g = np.zeros(size)
    g[2 * n:3 * n] = ep.sys.force
    x, w, xi = y_epmc[:-2], float(y_epmc[-2]), float(y_epmc[-1])
    F = -float(g @ (xi * (ep._mass_damping(w) @ x))) / float(g @ g)
    y = np.r_[x, w, F]
    K = ep.sys.linear_stiffness()
    fscale = max(np.linalg.norm(K @ x[ep._ic1]), 1e-300)
    res = np.inf
    for _ in range(NEWTON_MAX):
        x, w, F = y[:-2], y[-2], y[-1]
        R, J = hb.residual(x, w, 0.0, jacobian=True)
        G = np.empty(size + 2)
        G[:-2] = R + F * g
        G[-2] = ep.r @ x[ep._is1]
        G[-1] = ep.r @ x[ep._ic1] - a
        res = max(np.linalg.norm(G[:-2]) / fscale, abs(G[-1]) / a, abs(G[-2]) / a)
        if res < TOL:
            return float(w), float(F)
        A = np.zeros((size + 2, size + 2))
        A[:-2, :-2] = J
        A[:-2, -2] = hb.d_dw(x, w, 0.0)
        A[:-2, -1] = g
        A[-2, ep._is1] = ep.r
        A[-1, ep._ic1] = ep.r
        y = y + lu_solve(lu_factor(A), -G)
    if res < 1e2 * TOL:
        return float(y[-2]), float(y[-1])
    raise ConvergenceError(f"forced phase resonance did not converge at amplitude {a:.4g} m at "
                           f"{ep.output} (relative residual {res:.3g} after {NEWTON_MAX} Newton iterations)")


def apparent_mass(ep: EPMC, y: np.ndarray) -> float:
    """The apparent modal mass (kg) between the excitation and the sensor of the EPMC's
    nonlinear mode at solution ``y``: phi^T M phi / (phi_d phi_s), phi its fundamental."""
    phi = y[ep._ic1]
    return float(phi @ ep.sys.M @ phi) / float((ep.sys.force @ phi) * (ep.r @ phi))


def phase_resonance_points(ep: EPMC, amplitudes, sols: np.ndarray) -> np.ndarray:
    """(P, 3): frequency (Hz), damping ratio and apparent modal mass (kg) of the forced
    phase resonance at each amplitude, from the EPMC's solutions ``sols`` there; the
    damping by the measurement's force balance zeta = F / (2 m w^2 a) with the model's own
    apparent mass m of its nonlinear mode there (module docstring)."""
    out = np.empty((len(amplitudes), 3))
    for i, (a, y) in enumerate(zip(amplitudes, sols)):
        w, F = forced_quadrature(ep, float(a), y)
        m = apparent_mass(ep, y)
        out[i] = w / (2 * np.pi), abs(F) / (2 * m * w * w * float(a)), m
    return out
