"""The compiled steady-state kernels of issue 32 item 6 (a structure diagnosis in seconds):
the batched law kernel against closed-form steady loops written here (Jenkins, Masing on
Segalman's backbone), its forward-mode derivative against difference quotients, a joint's
compiled moment against the linear closed form M = (r^2 / 2) k theta, and the compiled
harmonic balance (Newton and dx/dp) against the Python path on the same structure."""

import numpy as np
import pytest

import labjoint.structure.law as law_module
from labjoint.structure.hbm import HarmonicBalance
from labjoint.structure.joint import Joint
from labjoint.structure.law import JointLaw
from labjoint.structure.predict import FrfPredictor

N = 64
TAU = 2 * np.pi * np.arange(N) / N


def test_jenkins_steady_loop_is_the_closed_form_parallelogram():
    k, fs, U = 1e6, 10.0, 4e-5                  # slips: U > fs / k
    law = JointLaw("coulomb", {"coulomb.k": k, "coulomb.f_s": fs})
    assert law.kernel_terms is not None
    u = U * np.cos(TAU)
    f = law.periodic(u, 0 * u, 0 * u, 1.0)[0]
    # from the top (force f_s): unloading k (U - u) until -f_s, then sliding; back up alike
    down = TAU <= np.pi
    closed = np.where(down, np.maximum(fs - k * (U - u), -fs), np.minimum(-fs + k * (u + U), fs))
    np.testing.assert_allclose(f, closed, rtol=0, atol=1e-9 * fs)


def test_iwan_steady_loop_follows_masing_branches_of_segalmans_backbone():
    F_S, K_T, chi, beta = 50.0, 2e6, -0.5, 0.1
    law = JointLaw("iwan", {"iwan.F_S": F_S, "iwan.K_T": K_T, "iwan.chi": chi, "iwan.beta": beta})
    D = beta + (chi + 1) / (chi + 2)
    phi = F_S * (1 + beta) / (K_T * D)

    def g(x):                                  # Segalman's backbone, written here
        r = np.minimum(np.abs(x) / phi, 1.0)
        return np.sign(x) * F_S / D * ((1 + beta) * r - r ** (chi + 2) / (chi + 2))

    U = 0.6 * phi                               # micro-slip
    u = U * np.cos(TAU)
    f = law.periodic(u, 0 * u, 0 * u, 1.0)[0]
    down = TAU <= np.pi
    closed = np.where(down, g(U) - 2 * g((U - u) / 2), -g(U) + 2 * g((u + U) / 2))
    np.testing.assert_allclose(f, closed, rtol=1e-12, atol=1e-12 * F_S)


LAWS = {
    "linear_stiffness+iwan+viscous": {"linear_stiffness.k": 1e9, "iwan.K_T": 1e10, "iwan.F_S": 3e4,
                                      "iwan.chi": -0.5, "iwan.beta": 0.1, "viscous.c": 1e6},
    "coulomb+richard_abbott+offset": {"coulomb.k": 1e9, "coulomb.f_s": 1e4, "richard_abbott.ke": 1e10,
                                      "richard_abbott.kp": 1e8, "richard_abbott.F_y": 2e4,
                                      "richard_abbott.n": 2.0, "offset.F0": 50.0},
    "linear_stiffness+cubic_stiffness+inertia+contact": {
        "linear_stiffness.k": 1e9, "cubic_stiffness.k3": 1e19, "inertia.m": 2.0,
        "contact.k_c": -1e9, "contact.gap": 2e-6},
}


@pytest.mark.parametrize("expr", sorted(LAWS))
def test_kernel_derivative_is_the_limit_of_difference_quotients(expr):
    law = JointLaw(expr, LAWS[expr])
    assert law.kernel_terms is not None
    H, w = 3, 180.0
    m = 2 * H + 1
    E = np.ones((N, m))
    E[:, 1::2] = np.cos(np.outer(TAU, np.arange(1, H + 1)))
    E[:, 2::2] = np.sin(np.outer(TAU, np.arange(1, H + 1)))
    Dm = np.zeros((m, m))
    for k in range(1, H + 1):
        Dm[2 * k - 1, 2 * k], Dm[2 * k, 2 * k - 1] = k, -k
    T = (E, E @ Dm * w, E @ Dm @ Dm * w * w)
    rng = np.random.default_rng(3)
    Q = rng.normal(size=(4, m)) * np.array([0.3, 1, 1, 0.2, 0.2, 0.1, 0.1]) * 3e-5
    s = np.array([1.0, -1.0, 0.5, 2.0])
    args = lambda Q: [s[:, None] * (Q @ Tx.T) for Tx in T]   # noqa: E731
    F, dF = law.periodic_tangent(*args(Q), 1.0, s, T, np.full(4, 1e-12))
    np.testing.assert_array_equal(F, law.periodic(*args(Q), 1.0))
    h = 1e-7 * np.linalg.norm(Q, axis=1)
    fd = np.stack([(law.periodic(*args(Q + h[:, None] * np.eye(m)[j]), 1.0)
                    - law.periodic(*args(Q - h[:, None] * np.eye(m)[j]), 1.0)) / (2 * h[:, None])
                   for j in range(m)], axis=2)
    assert np.max(np.abs(dF - fd)) < 1e-5 * np.max(np.abs(fd))


def test_compiled_joint_moment_is_the_linear_closed_form():
    k, r = 3e9, 0.05
    j = Joint("j", 0, 1, JointLaw("linear_stiffness", {"linear_stiffness.k": k}), r, 8, 1e9)
    th = 1e-4 * np.cos(TAU)[None, :]
    M = j.moment_periodic(th, 0 * th, 0 * th, 1.0)
    np.testing.assert_allclose(M[0], r * r / 2 * k * th[0], rtol=1e-12)


def _beam():
    import test_structure_independent as ti
    return ti.structure()


def test_compiled_harmonic_balance_is_the_python_path(monkeypatch):
    params = {"linear_stiffness.k": 3e9, "iwan.K_T": 1e9, "iwan.F_S": 200.0, "iwan.chi": -0.5,
              "iwan.beta": 0.1, "viscous.c": 1e4}
    pr = FrfPredictor(_beam(), modes=4, harmonics=3, samples=32)
    w = 2 * np.pi * 0.99 * pr.natural_frequencies(1)[0]

    def solve(kernel: bool):
        monkeypatch.setattr(law_module, "KERNEL", kernel)
        law = JointLaw("linear_stiffness+iwan+viscous", params)
        hb = HarmonicBalance(pr.system_with(law), 3, 32)
        assert (hb._fast is not None) == kernel
        x = hb.solve(w, 16.5, tol=1e-11)
        d = 1e-6 * params["iwan.F_S"]
        pert = HarmonicBalance(pr.system_with(law.with_params(**{"iwan.F_S": params["iwan.F_S"] + d})), 3, 32)
        return x, hb.sensitivity(x, w, 16.5, [pert], [d])[:, 0]

    x1, s1 = solve(True)
    x0, s0 = solve(False)
    assert np.max(np.abs(x1 - x0)) < 1e-8 * np.max(np.abs(x0))
    assert np.max(np.abs(s1 - s0)) < 1e-4 * np.max(np.abs(s0))
    assert np.max(np.abs(s0)) > 0                # the slip force moves the response
