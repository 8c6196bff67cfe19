"""Fits recover known parameters from noisy synthetic data built by closed forms (not by
the model's simulation code)."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.models import ModelFitter, RunData

FS = 25600.0


def sine(U: float, f: float, cycles: int):
    t = np.arange(int(round(cycles * FS / f))) / FS
    ph = np.mod(2 * np.pi * f * t, 2 * np.pi)
    return t, ph, U * np.sin(ph)


def jenkins_loop(u: np.ndarray, ph: np.ndarray, k: float, fs_: float) -> np.ndarray:
    """Relaxed Jenkins element under u = U sin: virgin min(k u, f_s) to the first peak,
    then the steady parallelogram between the sampled extremes."""
    lo, hi = u.min(), u.max()
    rising = (ph < np.pi / 2) | (ph >= 3 * np.pi / 2)
    F = np.where(rising, np.minimum(-fs_ + k * (u - lo), fs_), np.maximum(fs_ - k * (hi - u), -fs_))
    first = np.arange(u.size) <= np.argmax(u)
    F[first] = np.minimum(k * u[first], fs_)
    return F


def segalman_g(x, F_S, K_T, chi, beta):
    d = beta + (chi + 1) / (chi + 2)
    phi_max = F_S * (1 + beta) / (K_T * d)
    r = np.minimum(np.abs(x) / phi_max, 1.0)
    return np.sign(x) * F_S / d * ((1 + beta) * r - r ** (chi + 2) / (chi + 2))


def iwan_loop(u, ph, **p):
    """Iwan under u = U sin: virgin backbone to the first peak, then Masing branches
    F = -+g(U) +- 2 g((U +- u)/2) (exact for a parallel Iwan network)."""
    g = lambda x: segalman_g(x, **p)  # noqa: E731
    lo, hi = u.min(), u.max()
    down = (ph >= np.pi / 2) & (ph < 3 * np.pi / 2)
    F = np.where(down, g(hi) - 2 * g((hi - u) / 2), g(lo) + 2 * g((u - lo) / 2))
    first = np.arange(u.size) <= np.argmax(u)
    F[first] = g(u[first])
    return F


def noisy_run(u, F, f, rng, name, rel_noise=0.01):
    Fn = F + rng.normal(0, rel_noise * np.abs(F).max(), F.size)
    n1 = int(FS / f)
    return RunData.from_arrays(u, Fn, FS, frequency_hz=f, steady=(n1, u.size), name=name)


def within(res, true: dict, n_sigma: float = 4.0, rel: float = 0.03):
    for k, v in true.items():
        p = res.params_[k]
        assert abs(p.value - v) < max(n_sigma * p.stderr, 1e-12), (k, p.value, v, p.stderr)
        assert p.value == pytest.approx(v, rel=rel), k


def test_linear_stiffness_plus_viscous_is_exact_linear_least_squares():
    rng = np.random.default_rng(0)
    k, c = 3e6, 1500.0
    runs = []
    for f in (100.0, 200.0):
        for U in (5e-6, 15e-6):
            t, ph, u = sine(U, f, 6)
            F = k * u + c * 2 * np.pi * f * U * np.cos(ph)       # analytic velocity
            runs.append(noisy_run(u, F, f, rng, f"{f}-{U}"))
    res = ModelFitter("linear_stiffness+viscous").fit(runs)
    assert res.success_ and "exact" in res.message_ and res.start_costs_ and len(res.start_costs_) == 1
    within(res, {"linear_stiffness.k": k, "viscous.c": c}, rel=0.02)
    assert res.nrmse_ == pytest.approx(0.01 * np.sqrt(2), rel=0.15)   # noise only


def test_coulomb_recovered_from_closed_form_loops():
    rng = np.random.default_rng(1)
    k, fs_ = 2e7, 40.0
    runs = []
    for U in (3e-6, 6e-6, 12e-6):
        t, ph, u = sine(U, 200.0, 8)
        runs.append(noisy_run(u, jenkins_loop(u, ph, k, fs_), 200.0, rng, f"U{U}"))
    res = ModelFitter("coulomb").fit(runs)
    assert res.success_
    within(res, {"coulomb.k": k, "coulomb.f_s": fs_})


def test_iwan_with_linear_stiffness_recovered_from_closed_form_masing_loops():
    rng = np.random.default_rng(2)
    true = dict(F_S=80.0, K_T=1.5e7, chi=-0.4, beta=0.2)
    k = 2e6
    runs = []
    for f in (200.0, 400.0):
        for U in (2e-6, 5e-6, 12e-6, 30e-6):
            t, ph, u = sine(U, f, 6)
            runs.append(noisy_run(u, k * u + iwan_loop(u, ph, **true), f, rng, f"{f}-{U}"))
    res = ModelFitter("linear_stiffness+iwan", seed=0).fit(runs)
    assert res.success_
    within(res, {"linear_stiffness.k": k, **{f"iwan.{a}": b for a, b in true.items()}})
    assert res.nrmse_ < 0.02
