"""Harmonic balance, continuation, time integration and Craig-Bampton against closed forms."""

from pathlib import Path

import numpy as np
import pytest

from labjoint.structure import JointLaw, load_structure
from labjoint.structure.continuation import continuation
from labjoint.structure.hbm import ConvergenceError, HarmonicBalance
from labjoint.structure.modal import modes, with_parameter
from labjoint.structure.reduction import reduced_system
from labjoint.structure.system import NonlinearSystem
from labjoint.structure.timeint import steady_state

SEED000 = Path(__file__).resolve().parent.parent / "configs" / "structure-seed000.toml"
M, K, KJ, FS = 1.0, 1e4, 2e4, 5.0


def jenkins(c):
    return NonlinearSystem.sdof(M, c, K, JointLaw("coulomb", {"coulomb.k": KJ, "coulomb.f_s": FS}))


def describing_function_force(A, w, c):
    """Force amplitude the exact one-harmonic (describing-function) balance needs for a
    response amplitude A of m x'' + c x' + k x + Jenkins(x) (elastic-perfectly plastic)."""
    xy = FS / KJ
    if A <= xy:
        Cq, Sq = KJ * A, 0.0
    else:
        th = np.arccos(1 - 2 * xy / A)
        Cq, Sq = KJ * A / np.pi * (th - 0.5 * np.sin(2 * th)), -(4 * FS / np.pi) * (1 - xy / A)
    return np.hypot((K - M * w * w) * A + Cq, c * w * A - Sq)


@pytest.mark.parametrize("force", [4.0, 8.0])
def test_one_harmonic_hbm_equals_describing_function_along_the_curve(force):
    hb = HarmonicBalance(jenkins(0.3), harmonics=1, samples=1024)
    curve = continuation(hb, force, 10.0, 40.0)
    A = np.abs(curve.phasors()[:, 1, 0])
    w = 2 * np.pi * curve.frequencies_hz
    err = [describing_function_force(a, ww, 0.3) / force - 1 for a, ww in zip(A, w)]
    assert np.max(np.abs(err)) < 1e-3
    assert A.max() > 2 * FS / KJ                              # it slips near resonance
    assert curve.frequencies_hz[-1] == pytest.approx(40.0)


def test_continuation_follows_the_folds_of_a_duffing_oscillator():
    k3, c, F = 1e10, 2.0, 1.0
    law = JointLaw("cubic_stiffness", {"cubic_stiffness.k3": k3})
    hb = HarmonicBalance(NonlinearSystem.sdof(M, c, K, law), harmonics=1, samples=64)
    curve = continuation(hb, F, 10.0, 40.0)
    A = np.abs(curve.phasors()[:, 1, 0])
    w = 2 * np.pi * curve.frequencies_hz
    closed = np.hypot((K - M * w * w) * A + 0.75 * k3 * A ** 3, c * w * A)   # one-harmonic balance
    assert np.max(np.abs(closed / F - 1)) < 1e-6
    assert len(curve.turning_points_hz) == 2                 # the jump up and the jump down
    lo, hi = sorted(curve.turning_points_hz)
    assert 15 < lo < hi < 40


def test_multi_harmonic_hbm_equals_time_integration_to_steady_state():
    sysm = jenkins(8.0)
    hb = HarmonicBalance(sysm, harmonics=7, samples=512)
    for f in (22.0, 26.0):
        P = hb.phasors(hb.solve(2 * np.pi * f, 4.0))[:, 0]
        ss = steady_state(sysm, 4.0, f, harmonics=7, steps_per_period=256, tol=1e-7)
        assert abs(ss.phasors[1, 0] - P[1]) < 0.01 * abs(P[1])
        assert abs(ss.phasors[3, 0] - P[3]) < 0.05 * abs(P[3])
        assert abs(P[3]) > 5e-3 * abs(P[1])                 # the third harmonic is there


def test_even_harmonics_come_from_an_asymmetric_law():
    law = JointLaw("coulomb+asymmetric_slip", {"coulomb.k": KJ, "coulomb.f_s": FS, "asymmetric_slip.asym": 0.5})
    hb = HarmonicBalance(NonlinearSystem.sdof(M, 8.0, K, law), harmonics=4, samples=512)
    P = hb.phasors(hb.solve(2 * np.pi * 24.0, 3.0))[:, 0]
    assert abs(P[0]) > 1e-2 * abs(P[1])                     # harmonic 0: a mean offset
    sym = HarmonicBalance(jenkins(8.0), harmonics=4, samples=512)
    Ps = sym.phasors(sym.solve(2 * np.pi * 24.0, 3.0))[:, 0]
    assert abs(Ps[0]) < 1e-9 * abs(Ps[1]) and abs(Ps[2]) < 1e-9 * abs(Ps[1])


def test_continuation_that_cannot_converge_raises_instead_of_returning_a_curve():
    hb = HarmonicBalance(jenkins(0.3), harmonics=1, samples=256)
    with pytest.raises(ConvergenceError, match="Hz"):
        continuation(hb, 3.0, 10.0, 40.0, max_points=5)


def test_craig_bampton_matches_the_unreduced_structure():
    s = with_parameter(load_structure(SEED000), "E_e_pa", 2.2e7)
    full = modes(s, 3).frequencies_hz
    errs = []
    for n in (2, 5, 10):
        sysr, red = reduced_system(s, n)
        from scipy.linalg import eigh
        w2 = eigh(sysr.linear_stiffness(), sysr.M, eigvals_only=True)[:3]
        errs.append(np.abs(np.sqrt(w2) / (2 * np.pi) / full - 1))
    assert errs[-1].max() < 1e-3 and errs[-1].max() < errs[0].max()
    # the nonlinear response at one frequency agrees with the unreduced model
    hf = HarmonicBalance(NonlinearSystem.from_structure(s), 3, 128)
    hr = HarmonicBalance(reduced_system(s, 10)[0], 3, 128)
    w = 2 * np.pi * 20.0
    a = hf.phasors(hf.solve(w, 16.5))[1]
    b = hr.phasors(hr.solve(w, 16.5))[1]
    assert np.max(np.abs(a - b)) < 1e-3 * np.max(np.abs(a))
