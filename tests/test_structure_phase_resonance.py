"""The model's forced phase resonance (labjoint.structure.phase_resonance) against closed
forms: a linear 2-DOF system's drive-point quadrature (other mode off resonance) and a
single DOF with a cubic spring, where it is the EPMC's own point."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from labjoint.structure.epmc import EPMC
from labjoint.structure.law import JointLaw
from labjoint.structure.phase_resonance import phase_resonance_points
from labjoint.structure.system import LawElement, NonlinearSystem


def two_dof(k_law: float = 2e4) -> NonlinearSystem:
    """Masses 1 and 0.5 kg: ground -k1- m1 -k2- m2, the law (linear) between ground and m1,
    non-proportional dashpots; force and sensor on m2."""
    M = np.diag([1.0, 0.5])
    K = np.array([[4e4 + 3e4, -3e4], [-3e4, 3e4]])
    C = np.array([[9.0, -2.0], [-2.0, 4.0]])
    law = JointLaw("linear_stiffness", {"linear_stiffness.k": k_law})
    return NonlinearSystem(M, C, K, np.array([0.0, 1.0]), np.array([[1.0, 0.0]]), (LawElement(law),),
                           np.eye(2), ("m1", "m2"))


def test_a_linear_two_dof_systems_forced_quadrature_is_the_closed_forms_not_the_epmcs():
    s = two_dof()
    Kt = s.K + 2e4 * np.diag([1.0, 0.0])

    def H(w):                                            # m2 per unit force on m2, closed form
        return np.linalg.solve(Kt - w * w * s.M + 1j * w * s.C, s.force)[1]

    lam = np.sort(np.linalg.eigvals(np.linalg.solve(s.M, Kt)).real)
    w1 = math.sqrt(lam[0])
    wq = brentq(lambda w: H(w).real, 0.9 * w1, 1.1 * w1, xtol=1e-13)     # quadrature
    a = 2e-3
    F = a / abs(H(wq))
    ep = EPMC(s, 0, 3, 32, "m2")
    bb, sols = ep.backbone([a])
    (f, z, m), = phase_resonance_points(ep, [a], sols)
    assert f == pytest.approx(wq / (2 * np.pi), rel=1e-10)
    assert z == pytest.approx(F / (2 * m * wq * wq * a), rel=1e-9)
    # the apparent mass of mode 1 at the drive point (the EPMC's shape: the undamped mode's
    # up to the non-proportional damping's small imaginary part)
    lam_, phi = np.linalg.eig(np.linalg.solve(s.M, Kt))
    p = phi[:, np.argmin(lam_.real)].real
    assert m == pytest.approx(p @ s.M @ p / p[1] ** 2, rel=1e-3)
    # with non-proportional damping and one force the two definitions differ measurably
    assert abs(bb.points[0].frequency_hz - f) > 1e-6 * f


def test_a_single_dof_with_a_cubic_spring_is_the_epmc_point_and_its_force_balance():
    m, c, k, k3 = 2.0, 3.0, 8e4, 2e8
    s = NonlinearSystem.sdof(m, c, k, JointLaw("cubic_stiffness", {"cubic_stiffness.k3": k3}))
    ep = EPMC(s, 0, 5, 64, "x")
    A = np.array([1e-3, 3e-3])
    bb, sols = ep.backbone(A)
    out = phase_resonance_points(ep, A, sols)
    assert out[:, 2] == pytest.approx([m, m], rel=1e-12)
    for (f, z, _), p, a in zip(out, bb.points, A):
        assert f == pytest.approx(p.frequency_hz, rel=1e-7)     # (the harmonics: 3e-9 apart)
        # the force at quadrature balances the dashpot alone: F = c w a, up to what the
        # dashpot takes from the harmonics (9 (X3 / X1)^2: < 1e-5 here)
        assert z == pytest.approx(c * 2 * np.pi * f * a / (2 * m * (2 * np.pi * f) ** 2 * a), rel=1e-4)
        wn1 = math.sqrt((k + 0.75 * k3 * a * a) / m)     # first-harmonic backbone (cubic: small harmonics)
        assert 2 * np.pi * f == pytest.approx(wn1, rel=1e-3)
