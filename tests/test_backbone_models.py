"""Modelled backbones: the single-DOF modal form (labjoint.structure.sdof_backbone) and the
extended periodic motion concept (labjoint.structure.epmc) against closed forms."""

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.structure.epmc import EPMC, epmc_backbone
from labjoint.structure.law import JointLaw
from labjoint.structure.sdof_backbone import sdof_backbone
from labjoint.structure.system import NonlinearSystem
from test_ringdown import jenkins_describing

M, K_LIN, C = 1.0, 3e4, 0.5
COULOMB = {"coulomb.k": 1e5, "coulomb.f_s": 1.0}


def test_sdof_cubic_stiffness_is_the_duffing_first_harmonic_closed_form():
    k, k3 = 1e4, 1e10
    law = JointLaw("linear_stiffness+cubic_stiffness", {"linear_stiffness.k": k, "cubic_stiffness.k3": k3})
    A = np.array([1e-5, 1e-4, 5e-4, 1e-3])
    h = sdof_backbone(law, A, M)
    assert h.array("frequency_hz") == pytest.approx(np.sqrt((k + 0.75 * k3 * A ** 2) / M) / (2 * np.pi), rel=1e-9)
    assert np.all(np.abs(h.array("damping_ratio")) < 1e-12)
    s = sdof_backbone(law, A, M, stiffness="secant")       # the loop's tip: k + k3 A^2
    assert s.array("frequency_hz") == pytest.approx(np.sqrt((k + k3 * A ** 2) / M) / (2 * np.pi), rel=1e-9)


def test_sdof_jenkins_masing_loop_gives_the_describing_function_and_the_vocabulary_energy():
    law = JointLaw("coulomb", COULOMB)
    slip = COULOMB["coulomb.f_s"] / COULOMB["coulomb.k"]
    A = np.geomspace(0.3 * slip, 100 * slip, 9)
    b = sdof_backbone(law, A, M, stiffness_n_per_m=K_LIN, damping_ns_per_m=C)
    for a, p in zip(A, b.points):
        k1, W = jenkins_describing(a, COULOMB["coulomb.k"], slip)
        K = K_LIN + k1
        w = np.sqrt(K / M)
        assert p.frequency_hz == pytest.approx(w / (2 * np.pi), rel=5e-5)   # 256 samples, kinked loop
        assert p.extra["dissipation_j"] == pytest.approx(W, rel=1e-4, abs=1e-18)   # 4 f_s (A - f_s/k)
        assert p.damping_ratio == pytest.approx(W / (2 * np.pi * K * a * a) + C / (2 * M * w), rel=2e-4)


def test_sdof_iwan_micro_slip_damping_follows_the_power_law():
    F_S, K_T, chi, beta = 10.0, 1e6, -0.5, 0.0
    law = JointLaw("iwan", {"iwan.F_S": F_S, "iwan.K_T": K_T, "iwan.chi": chi, "iwan.beta": beta})
    D = beta + (chi + 1) / (chi + 2)
    phi_max = F_S * (1 + beta) / (K_T * D)
    R = F_S * (chi + 1) / (phi_max ** (chi + 2) * D)
    A = phi_max * np.array([1e-5, 1e-4, 1e-3])
    b = sdof_backbone(law, A, M)
    W = 4 * R * A ** (3 + chi) / ((chi + 2) * (chi + 3))           # vocabulary, seed 001
    assert b.array("amplitude") == pytest.approx(A)
    assert [p.extra["dissipation_j"] for p in b.points] == pytest.approx(W, rel=2e-3)
    zeta = b.array("damping_ratio")
    slope = np.diff(np.log(zeta)) / np.diff(np.log(A))
    assert slope == pytest.approx(1 + chi, abs=0.02)              # zeta ~ A^(1 + chi) in micro-slip


def test_epmc_with_one_harmonic_is_the_single_dof_modal_form():
    law = JointLaw("coulomb", COULOMB)
    A = np.geomspace(1e-6, 1e-3, 12)
    e = epmc_backbone(NonlinearSystem.sdof(M, C, K_LIN, law), A, harmonics=1)
    s = sdof_backbone(law, A, M, stiffness_n_per_m=K_LIN, damping_ns_per_m=C)
    assert e.array("frequency_hz") == pytest.approx(s.array("frequency_hz"), rel=1e-7)
    assert e.array("damping_ratio") == pytest.approx(s.array("damping_ratio"), rel=1e-6)
    z = e.array("damping_ratio")
    assert z.max() > 100 * z.min()                                  # micro- to macro-slip


def test_epmc_linear_two_dof_modes_are_exact_and_duffing_converges_with_harmonics():
    Mm = np.diag([1.0, 2.0])
    Kk = np.array([[3e4, -1e4], [-1e4, 2e4]])
    Cc = 1e-4 * Kk + 0.3 * Mm                                        # Rayleigh: classical modes
    law = JointLaw("cubic_stiffness", {"cubic_stiffness.k3": 0.0})
    sel = np.array([[1.0, 0.0]])
    sysm = NonlinearSystem(Mm, Cc, Kk, np.array([0.0, 1.0]), sel, NonlinearSystem.sdof(1, 0, 1, law).elements,
                           np.eye(2), ("a", "b"))
    lam = np.sort(np.linalg.eigvals(np.linalg.solve(Mm, Kk)).real)
    for mode in (0, 1):
        wn = np.sqrt(lam[mode])
        b = epmc_backbone(sysm, [1e-6, 1e-3], mode=mode, sensor="b")
        assert b.array("frequency_hz") == pytest.approx(wn / (2 * np.pi), rel=1e-9)
        assert b.array("damping_ratio") == pytest.approx((1e-4 * wn + 0.3 / wn) / 2, rel=1e-7)
    # Duffing: H = 1 is the first-order closed form; more harmonics move it by O((e A^2)^2)
    k3 = 1e10
    duff = NonlinearSystem.sdof(M, 0.0, 1e4, JointLaw("cubic_stiffness", {"cubic_stiffness.k3": k3}))
    A = np.array([1e-4, 2e-4, 3e-4])                              # e A^2 up to 0.09
    one = epmc_backbone(duff, A, harmonics=1).array("frequency_hz")
    assert one == pytest.approx(np.sqrt((1e4 + 0.75 * k3 * A ** 2) / M) / (2 * np.pi), rel=1e-8)
    five = epmc_backbone(duff, A, harmonics=5).array("frequency_hz")
    assert five == pytest.approx(one, rel=3e-4) and not np.allclose(five, one, rtol=1e-6)


def test_bad_inputs_are_named():
    sysm = NonlinearSystem.sdof(M, C, K_LIN, JointLaw("coulomb", COULOMB))
    with pytest.raises(InputError) as e:
        EPMC(sysm, output="tip")
    assert e.value.field == "sensor"
    with pytest.raises(InputError) as e:
        epmc_backbone(sysm, [1e-6, -1.0])
    assert e.value.field == "amplitudes"
    with pytest.raises(InputError) as e:
        sdof_backbone(JointLaw("coulomb", COULOMB), [1e-6], 0.0)
    assert e.value.field == "mass_kg"
