"""Even (asymmetric) effects (issue 29 item 1): closed forms of the laws, the forward
simulator's balance, and the comparison loop on records from an independent generator
written here (displacement-driven sines and a random record with the force from the law
in closed form; a multisine-forced oscillator integrated by this file's own RK4)."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.compare import diagnose_runs, fit_runs
from labjoint.errors import InputError
from labjoint.models import Model, ModelInputs
from labjoint.models.asymmetry import asymmetry
from labjoint.models.effects import get_effect
from labjoint.models.simulate import simulate
from labjoint.storage import Run

K, C = 1e6, 50.0
K2 = 3e10                 # k2 U = 3e5 N/m at U = 10 um: the +u side 30 % stiffer there
KC, GAP = 5e5, 3e-6       # a contact on the +u side closing at 3 um
AMPS = (2e-6, 4e-6, 6e-6, 8e-6, 10e-6, 12e-6)


def joint_force(u, v, k2=0.0, kc=0.0, gap=0.0):
    """The generator's joint: k u + c v, a quadratic spring and a one-sided contact."""
    F = K * u + C * v + k2 * u * u
    if kc > 0:
        F = F + kc * np.where(u > gap, u - gap, 0.0)
    elif kc < 0:
        F = F - abs(kc) * np.where(u < -gap, -u - gap, 0.0)
    return F


def sine_set(tmp_path, law, freq=50.0, fs=5000.0, noise=0.002, seed=0, force=None,
             amps=AMPS, fmt="%.10g"):
    """CSV runs: a displacement sine ramped over 2 cycles (its velocity in closed form),
    the force from ``law`` plus Gaussian noise of ``noise`` x its rms."""
    rng = np.random.default_rng(seed)
    paths = []
    for i, a in enumerate(amps):
        t = np.arange(int(14 * fs / freq)) / fs
        w = 2 * np.pi * freq
        env = np.clip(t * freq / 2.0, 0, 1)
        denv = np.where(t * freq < 2, freq / 2, 0.0)
        u = a * env * np.sin(w * t)
        v = a * (env * w * np.cos(w * t) + denv * np.sin(w * t))
        F = (force or joint_force)(u, v, **law)
        F = F + noise * np.std(F) * rng.standard_normal(F.size)
        p = tmp_path / f"run{i}.csv"
        with open(p, "w") as fh:
            fh.write(f"# frequency_hz: {freq}\n# sample_rate_hz: {fs}\ntime_s,displacement_m,force_N\n")
            np.savetxt(fh, np.column_stack([t, u, F]), delimiter=",", fmt=fmt)
        paths.append(str(p))
    return paths


# -- the laws against their closed forms -------------------------------------------------
def _inputs(u):
    return ModelInputs(u, np.zeros_like(u), np.zeros_like(u), 1000.0)


def test_quadratic_stiffness_is_even_with_its_second_harmonic_in_closed_form():
    n, U = 400, 2e-5
    t = np.arange(n) / n
    u = U * np.sin(2 * np.pi * t)
    F = Model.parse("quadratic_stiffness").eval({"quadratic_stiffness.k2": K2}, _inputs(u))
    assert np.allclose(F, K2 * U ** 2 / 2 * (1 - np.cos(4 * np.pi * t)), rtol=0, atol=1e-9 * K2 * U ** 2)
    spec = np.fft.rfft(F) / n * 2
    assert abs(spec[2]) == pytest.approx(K2 * U ** 2 / 2, rel=1e-9)     # 2nd harmonic
    assert abs(spec[1]) < 1e-9 * abs(spec[2])


def test_bilinear_stiffness_has_two_slopes_and_contact_two_sides():
    u = np.linspace(-1e-5, 1e-5, 201)
    m = Model.parse("linear_stiffness+bilinear_stiffness")
    F = m.eval({"linear_stiffness.k": K, "bilinear_stiffness.dk": 4e5}, _inputs(u))
    assert np.allclose(F, np.where(u > 0, 1.4e6 * u, K * u), atol=1e-12)
    c = get_effect("contact")
    plus = c.elastic({"k_c": KC, "gap": GAP}, u)
    minus = c.elastic({"k_c": -KC, "gap": GAP}, u)
    assert np.allclose(plus, np.where(u > GAP, KC * (u - GAP), 0.0))
    assert np.allclose(minus, np.where(u < -GAP, KC * (u + GAP), 0.0))      # pushes back
    assert np.allclose(minus, -plus[::-1])                                   # mirror image
    # continuous in k_c through 0 (both sides vanish), batched over any shape
    assert np.max(np.abs(c.elastic({"k_c": 1e-9, "gap": GAP}, u))) < 1e-14
    batch = np.stack([u, 2 * u])
    assert np.allclose(c.elastic({"k_c": KC, "gap": GAP}, batch)[1],
                       c.elastic({"k_c": KC, "gap": GAP}, 2 * u))


def test_the_asymmetry_is_stated_in_words():
    (q,) = asymmetry(Model.parse("linear_stiffness+quadratic_stiffness"),
                     {"linear_stiffness.k": K, "quadratic_stiffness.k2": -K2}, 1e-5)
    assert q["stiffer_side"] == "-u" and q["ratio"] == pytest.approx(1.3 / 0.7)
    assert "the -u side is stiffer" in q["text"]
    (c,) = asymmetry(Model.parse("linear_stiffness+contact"),
                     {"linear_stiffness.k": K, "contact.k_c": KC, "contact.gap": GAP}, 1e-5)
    assert c["stiffer_side"] == "+u" and c["ratio"] == pytest.approx(1.5)
    assert "closes at u = +3e-06 m" in c["text"]


def test_the_forward_simulator_balances_the_even_laws():
    """The RK4 response under a multisine satisfies m a + c v + k y + (even law) = F as the
    models layer evaluates it (spectral derivatives of the periodic response)."""
    fs, n = 750.0, 1024
    rng = np.random.default_rng(2)
    f = np.fft.rfftfreq(n, 1 / fs)
    spec = np.where((f >= 5) & (f <= 150), np.exp(2j * np.pi * rng.random(f.size)), 0)
    F = np.fft.irfft(spec, n)
    F *= 50 / np.std(F)
    for expr, extra in (("quadratic_stiffness", {"quadratic_stiffness.k2": 1e6}),
                        ("bilinear_stiffness", {"bilinear_stiffness.dk": 2e4}),
                        ("contact", {"contact.k_c": -3e4, "contact.gap": 2e-4})):
        full = f"inertia+viscous+linear_stiffness+{expr}"
        p = {"inertia.m": 2.0, "viscous.c": 10.0, "linear_stiffness.k": 5e4, **extra}
        y = simulate(full, p, F, fs, periodic=True)
        sy = np.fft.rfft(y)
        jw = 2j * np.pi * f
        v, a = np.fft.irfft(sy * jw, n), np.fft.irfft(sy * jw * jw, n)
        bal = Model.parse(full).eval(p, ModelInputs(y, v, a, fs))
        assert np.sqrt(np.mean((bal - F) ** 2)) < 2e-2 * np.std(F), expr
    with pytest.raises(InputError, match="coulomb"):
        simulate("inertia+linear_stiffness+bouc_wen+asymmetric_slip",
                 {"inertia.m": 1.0, "linear_stiffness.k": 1.0, "bouc_wen.k0": 1.0,
                  "bouc_wen.alpha": 1.0, "bouc_wen.beta": 0.0, "bouc_wen.n": 1.0,
                  "asymmetric_slip.asym": 0.1}, F, fs)


def test_a_fit_recovers_the_quadratic_and_says_which_side_is_stiffer(tmp_path):
    res = fit_runs(sine_set(tmp_path, {"k2": K2}),
                   "linear_stiffness+viscous+quadratic_stiffness")
    assert res["parameters"]["quadratic_stiffness.k2"]["value"] == pytest.approx(K2, rel=0.02)
    (a,) = res["asymmetry"]
    assert a["stiffer_side"] == "+u" and "the +u side is stiffer" in a["text"]
    assert a["ratio"] == pytest.approx((K + K2 * 12e-6) / (K - K2 * 12e-6), rel=0.05)
    assert res["flags"] == {}


# -- diagnose names the even effect first -------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("law, effect", [({"k2": K2}, "quadratic_stiffness"),
                                         ({"kc": -KC, "gap": GAP}, "contact")])
def test_diagnose_names_the_even_effect_first_and_recovers_its_asymmetry(tmp_path, law, effect):
    res = diagnose_runs(sine_set(tmp_path, law), "linear_stiffness+viscous")
    best = res["candidates"][0]
    assert not res["adequate"] and best["effect"] == effect and best["significant"]
    assert res["verdict"].startswith(f"add {effect}")
    p = {k: v["value"] for k, v in best["parameters"].items()}
    if effect == "quadratic_stiffness":
        assert p["quadratic_stiffness.k2"] == pytest.approx(K2, rel=0.1)
    else:
        assert p["contact.k_c"] == pytest.approx(-KC, rel=0.1)
        assert p["contact.gap"] == pytest.approx(GAP, rel=0.1)
    (a,) = best["asymmetry"]
    U = max(AMPS)
    k_soft, k_stiff = (K - K2 * U, K + K2 * U) if effect == "quadratic_stiffness" else (K, K + KC)
    assert a["stiffer_side"] == ("+u" if effect == "quadratic_stiffness" else "-u")
    assert a["ratio"] == pytest.approx(k_stiff / k_soft, rel=0.1)


@pytest.mark.slow
def test_a_linear_viscous_joint_is_adequate(tmp_path):
    res = diagnose_runs(sine_set(tmp_path, {}), "linear_stiffness+viscous")
    assert res["adequate"], res["verdict"]


# -- along records: equation and simulation error ------------------------------------------
def _rk4_oscillator(F, fs, m, c, k, k2, sub=20):
    """This file's own integrator: m y'' + c y' + k y + k2 y^2 = F, F held linear between
    samples, classical RK4 with ``sub`` steps per sample, from rest."""
    h = 1.0 / (fs * sub)
    y = v = 0.0
    out = np.empty(F.size)
    out[0] = 0.0

    def acc(f, y, v):
        return (f - c * v - k * y - k2 * y * y) / m

    for i in range(F.size - 1):
        for s in range(sub):
            fa = F[i] + (F[i + 1] - F[i]) * s / sub
            fm = F[i] + (F[i + 1] - F[i]) * (s + 0.5) / sub
            fb = F[i] + (F[i + 1] - F[i]) * (s + 1) / sub
            k1y, k1v = v, acc(fa, y, v)
            k2y, k2v = v + 0.5 * h * k1v, acc(fm, y + 0.5 * h * k1y, v + 0.5 * h * k1v)
            k3y, k3v = v + 0.5 * h * k2v, acc(fm, y + 0.5 * h * k2y, v + 0.5 * h * k2v)
            k4y, k4v = v + h * k3v, acc(fb, y + h * k3y, v + h * k3v)
            y += h * (k1y + 2 * k2y + 2 * k3y + k4y) / 6
            v += h * (k1v + 2 * k2v + 2 * k3v + k4v) / 6
        out[i + 1] = y
    return out


@pytest.mark.slow
def test_simulation_error_diagnosis_names_the_quadratic_along_a_record():
    from labjoint.compare.simulation_loop import diagnose_simulation

    fs, n = 500.0, 4000
    rng = np.random.default_rng(4)
    f = np.fft.rfftfreq(n, 1 / fs)
    spec = np.where((f >= 5) & (f <= 60), np.exp(2j * np.pi * rng.random(f.size)), 0)
    F = np.fft.irfft(spec, n)
    F = np.concatenate([np.zeros(200), F * 40 / np.std(F)])
    m, c, k, k2 = 2.0, 10.0, 5e4, 1.5e6          # k2 U ~ 0.2 k at U ~ 6 mm
    y = _rk4_oscillator(F, fs, m, c, k, k2)
    y = y + 1e-7 * rng.standard_normal(y.size)
    run = Run("rec", np.arange(F.size) / fs, y, F, {"sample_rate_hz": fs})
    d = diagnose_simulation([run], "inertia+viscous+linear_stiffness",
                            candidates=["quadratic_stiffness", "cubic_stiffness", "offset",
                                        "contact", "bilinear_stiffness"])
    assert d.best is not None and d.best.effect == "quadratic_stiffness", d.verdict
    assert d.best.fit.params["quadratic_stiffness.k2"].value == pytest.approx(k2, rel=0.1)
    (a,) = d.best.fit.asymmetry()
    assert a["stiffer_side"] == "+u"


@pytest.mark.slow
def test_tied_candidates_go_by_fewer_parameters_and_the_ladder_takes_the_simpler(tmp_path):
    """A bilinear joint (kink at rest): a contact with its gap at ~0 is the same law with
    one parameter more; the two tie (the contact's extra parameter even lowers its NRMSE
    by a hair), and the simpler is named first, in any order given (issue 33 item 9)."""
    from labjoint.compare.api import diagnose_report, ladder_runs
    from labjoint.compare.ties import simpler_first

    def bilinear(u, v):
        return K * u + C * v + 3e5 * np.maximum(u, 0.0)

    runs = sine_set(tmp_path, {}, force=bilinear)
    d = diagnose_report(runs, "linear_stiffness+viscous",
                        candidates="bilinear_stiffness,contact")
    first, second = d.candidates[:2]
    assert first.effect == "bilinear_stiffness" and second.effect == "contact"
    assert first.tie_with == ["contact"] and "cannot be told apart" in first.tie_reason
    assert d.verdict.startswith("add bilinear_stiffness")
    assert [c.effect for c in simpler_first([second, first])][0] == "bilinear_stiffness"
    lad = ladder_runs(runs, "linear_stiffness+viscous", candidates="bilinear_stiffness,contact",
                      max_steps=1, save=False)
    assert lad["steps"][1]["added"] == "bilinear_stiffness"
