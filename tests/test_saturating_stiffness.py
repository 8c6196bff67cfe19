"""saturating_stiffness, F = k_s x_s tanh(u / x_s) (issue 29, the BERT beam's amplitude-
dependent stiffness without loss): its describing function against direct quadrature and
its closed-form limits, zero loss and odd harmonics, and the comparison loop on data from
generators written here: displacement-driven sines with the force in closed form, a
randomly forced oscillator and a two-mode structure integrated by scipy's solve_ivp."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from labjoint.compare import diagnose_report, fit_runs
from labjoint.models import Model, ModelInputs
from labjoint.models.effects import _steady, get_effect
from labjoint.models.effects.saturating import describing, keq_fit
from labjoint.models.simulate import simulate
from labjoint.storage import Run
from tests.test_even_effects import sine_set as even_sine_set

K, C = 1e6, 50.0
KS, XS = 3e5, 1e-6                            # 30 % softer beyond 1 um
AMPS = tuple(XS * a for a in (0.3, 1.0, 3.0, 10.0, 30.0))


def tanh_force(u, ks=KS, xs=XS):
    return ks * xs * np.tanh(u / xs)


def sine_set(tmp_path, ks=KS, xs=XS, freq=50.0, fs=5000.0, noise=0.002, seed=0):
    """CSV runs (tests/test_even_effects.py's generator): a displacement sine ramped over 2
    cycles, the force k u + c v + k_s x_s tanh(u / x_s) plus Gaussian noise of ``noise`` x
    its rms."""
    return even_sine_set(tmp_path, {}, freq=freq, fs=fs, noise=noise, seed=seed, amps=AMPS,
                         fmt="%.12g", force=lambda u, v: K * u + C * v + tanh_force(u, ks, xs))


# -- the law and its describing function ----------------------------------------------------
def test_describing_function_matches_quadrature_and_its_limits():
    for a in (1e-4, 0.05, 0.3, 1.0, 2.5, 10.0, 30.0, 300.0):
        q = quad(lambda t: np.tanh(a * np.sin(t)) * np.sin(t), 0, np.pi, limit=400)[0]
        assert describing(a)[()] == pytest.approx(2 / (np.pi * a) * q, rel=1e-6), a
    assert describing(0.0)[()] == 1.0
    a = np.array([1e-3, 1e-2, 0.05])
    assert np.allclose(describing(a), 1 - a**2 / 4, rtol=0, atol=a**4)       # D = 1 - a^2/4 + O(a^4)
    a = np.array([50.0, 200.0, 1000.0])
    assert np.allclose(describing(a) * np.pi * a / 4, 1.0, rtol=5 / a**2)    # 4 / (pi a)
    assert np.all(np.diff(describing(np.geomspace(1e-2, 1e3, 50))) < 0)     # softening, monotone


def test_force_is_odd_without_loss_and_its_first_harmonic_is_the_describing_function():
    eff = get_effect("saturating_stiffness")
    n = 4096
    t = np.arange(n) / n
    for U in (0.3 * XS, 3 * XS, 30 * XS):
        u = U * np.sin(2 * np.pi * t)
        F = eff.elastic({"k_s": KS, "x_s": XS}, u)
        assert np.allclose(F, tanh_force(u), rtol=1e-12, atol=0)
        spec = np.fft.rfft(F) / n * 2
        assert -spec[1].imag == pytest.approx(KS * U * describing(U / XS)[()], rel=1e-9)
        assert abs(spec[1].real) < 1e-9 * abs(spec[1])               # in phase: no loss
        assert np.max(np.abs(spec[0:12:2])) < 1e-9 * abs(spec[1])    # odd harmonics only
        v = np.cos(2 * np.pi * t) * 2 * np.pi * U                     # per unit period
        assert abs(np.sum(F * v) / n) < 1e-12 * KS * U * U            # energy per cycle: 0
    assert eff.elastic({"k_s": KS, "x_s": 0.0}, np.ones(3)).tolist() == [0.0] * 3
    # the steady (harmonic-balance) kernel's code: the same force and its slope
    u = np.linspace(-5 * XS, 5 * XS, 101)
    code, p = eff.steady_term({"k_s": KS, "x_s": XS})
    for ui in u[::10]:
        f, df, _, _ = _steady.memoryless(code, np.r_[p, 0.0, 0.0, 0.0], ui, 0.0, 0.0)
        assert f == pytest.approx(tanh_force(ui), rel=1e-12, abs=1e-20)
        assert df == pytest.approx(KS / np.cosh(ui / XS) ** 2, rel=1e-12)


def test_keq_fit_recovers_the_law_from_equivalent_stiffnesses():
    U = np.geomspace(0.3, 30, 6) * XS
    got = keq_fit(U, K + KS * describing(U / XS))
    assert got[0] == pytest.approx(K, rel=1e-3)
    assert got[1] == pytest.approx(KS, rel=0.1) and got[2] == pytest.approx(XS, rel=0.15)
    assert keq_fit(U[:2], K + KS * describing(U[:2] / XS)) is None


def test_the_forward_simulator_balances_the_law():
    fs, n = 750.0, 1024
    rng = np.random.default_rng(2)
    f = np.fft.rfftfreq(n, 1 / fs)
    spec = np.where((f >= 5) & (f <= 150), np.exp(2j * np.pi * rng.random(f.size)), 0)
    F = np.fft.irfft(spec, n)
    F *= 50 / np.std(F)
    full = "inertia+viscous+linear_stiffness+saturating_stiffness"
    p = {"inertia.m": 2.0, "viscous.c": 10.0, "linear_stiffness.k": 5e4,
         "saturating_stiffness.k_s": 3e4, "saturating_stiffness.x_s": 2e-4}
    y = simulate(full, p, F, fs, periodic=True)
    assert np.ptp(y) > 10 * 2e-4                                   # well into saturation
    sy = np.fft.rfft(y)
    jw = 2j * np.pi * f
    v, a = np.fft.irfft(sy * jw, n), np.fft.irfft(sy * jw * jw, n)
    bal = Model.parse(full).eval(p, ModelInputs(y, v, a, fs))
    assert np.sqrt(np.mean((bal - F) ** 2)) < 2e-2 * np.std(F)


# -- joint-level sines: fit, diagnose, null ---------------------------------------------------
def test_a_fit_of_sines_recovers_k_s_and_x_s(tmp_path):
    res = fit_runs(sine_set(tmp_path), "linear_stiffness+viscous+saturating_stiffness")
    p = {k: v["value"] for k, v in res["parameters"].items()}
    assert p["saturating_stiffness.k_s"] == pytest.approx(KS, rel=0.05)
    assert p["saturating_stiffness.x_s"] == pytest.approx(XS, rel=0.05)
    assert p["linear_stiffness.k"] == pytest.approx(K, rel=0.02)


def test_diagnose_names_the_saturating_stiffness_not_the_cubic(tmp_path):
    d = diagnose_report(sine_set(tmp_path), "linear_stiffness+viscous",
                        candidates="cubic_stiffness,saturating_stiffness,iwan", n_jobs=1)
    assert not d.adequate and d.best is not None, d.verdict
    assert d.best.effect == "saturating_stiffness" and not d.best.tie_with, d.verdict
    assert d.verdict.startswith("add saturating_stiffness")
    p = d.best.fit.params_
    assert p["saturating_stiffness.k_s"].value == pytest.approx(KS, rel=0.05)
    assert p["saturating_stiffness.x_s"].value == pytest.approx(XS, rel=0.05)


def test_the_default_list_tries_it_only_when_named(tmp_path):
    """A joint-level diagnosis tries saturating_stiffness when named (it would otherwise name
    a gap, backlash's dead zone, as a smooth stiffening: tests/test_hidden_effects_effects),
    and says so; named among the others it is the one found."""
    from labjoint.compare.candidates import ON_REQUEST, candidate_effects
    m = Model.parse("linear_stiffness+viscous")
    names, skipped = candidate_effects(m)
    assert "saturating_stiffness" not in names and "backlash" in names
    assert skipped["saturating_stiffness"] == ON_REQUEST["saturating_stiffness"]
    assert "saturating_stiffness" in candidate_effects(m, ["saturating_stiffness"])[0]
    d = diagnose_report(sine_set(tmp_path), "linear_stiffness+viscous",
                        candidates="cubic_stiffness,backlash,quadratic_stiffness,coulomb,"
                                   "saturating_stiffness")
    assert d.best is not None and d.best.effect == "saturating_stiffness", \
        (d.verdict, [(c.effect, c.nrmse_after_validation) for c in d.candidates[:4]])
    assert "cubic_stiffness" not in d.best.tie_with


def test_null_linear_joint_saturating_stiffness_is_not_significant(tmp_path):
    runs = sine_set(tmp_path, ks=0.0)
    d = diagnose_report(runs, "linear_stiffness+viscous",
                        candidates="saturating_stiffness,cubic_stiffness", n_jobs=1)
    assert d.adequate and d.best is None, d.verdict
    # a baseline without its damping: the candidates are fitted, and the saturating law,
    # which has no loss and nothing to follow in amplitude here, is not significant
    d = diagnose_report(runs, "linear_stiffness",
                        candidates="saturating_stiffness,viscous", n_jobs=1)
    sat = next(c for c in d.candidates if c.effect == "saturating_stiffness")
    assert d.best is not None and d.best.effect == "viscous", d.verdict
    assert not sat.significant, sat.reason
    # fitted anyway, the equivalent stiffness k + k_s D(U / x_s) varies by < 0.5 % over the
    # amplitudes (x_s far above them makes k_s a share of the linear stiffness: no change)
    res = fit_runs(runs, "linear_stiffness+viscous+saturating_stiffness")
    p = {k: v["value"] for k, v in res["parameters"].items()}
    dk = p["saturating_stiffness.k_s"] * describing(np.array(AMPS) / p["saturating_stiffness.x_s"])
    assert np.ptp(dk) < 5e-3 * K


# -- a randomly forced oscillator along a record -----------------------------------------------
TRUE_SDOF = dict(m=1.0, c=40.0, k=4e4, ks=1.2e4, xs=1e-4)      # f0 32 Hz, zeta 0.1


def _random_record(level, seed, fs=2000.0, seconds=6.0, band=(5.0, 60.0)):
    """m y'' + c y' + k y + k_s x_s tanh(y / x_s) = F(t), F a random-phase multisine of
    40 lines in ``band`` (the resonance inside it: the record kind's derivatives stop
    above the excited band) of ``level`` N each (in closed form between samples), solved by
    DOP853 from rest; the force measured with white noise."""
    m, c, k, ks, xs = (TRUE_SDOF[n] for n in ("m", "c", "k", "ks", "xs"))
    rng = np.random.default_rng(seed)
    w = 2 * np.pi * np.sort(rng.uniform(*band, 40))
    ph = 2 * np.pi * rng.random(40)

    def force(t):
        return level * np.sum(np.sin(np.multiply.outer(t, w) + ph), axis=-1)

    def rhs(ti, s):
        return [s[1], (force(ti) - c * s[1] - k * s[0] - ks * xs * np.tanh(s[0] / xs)) / m]

    t = np.arange(int(seconds * fs)) / fs
    sol = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], t_eval=t, method="DOP853", rtol=1e-9, atol=1e-13)
    F = force(t)
    F = F + 1e-3 * np.std(F) * rng.standard_normal(t.size)        # the force sensor's noise
    return Run(f"rec{seed}", t, sol.y[0], F, {"sample_rate_hz": fs})


def test_records_fit_by_simulation_error_recovers_k_s_and_x_s():
    """Three random records, their peaks from below x_s / 2 to beyond 30 x_s, fitted by
    simulation error (the record kind's equation error differentiates the displacement
    within the excited band, which leaves out the harmonics the tanh force puts into the
    acceleration: 3 % residual at the true parameters on the middle record)."""
    from labjoint.compare.output_error import fit_simulation

    runs = [_random_record(lv, i, fs=1000.0) for i, lv in enumerate((0.05, 0.5, 5.0))]
    xs = TRUE_SDOF["xs"]
    peaks = [np.max(np.abs(r.displacement)) for r in runs]
    assert peaks[0] < 0.5 * xs and peaks[-1] > 30 * xs, peaks
    fit = fit_simulation(runs, "inertia+viscous+linear_stiffness+saturating_stiffness", warmup=0.2)
    p = {k: v.value for k, v in fit.params.items()}
    assert p["saturating_stiffness.k_s"] == pytest.approx(TRUE_SDOF["ks"], rel=0.05)
    assert p["saturating_stiffness.x_s"] == pytest.approx(xs, rel=0.05)
    assert p["linear_stiffness.k"] == pytest.approx(TRUE_SDOF["k"], rel=0.02)


# -- the modal kind: a two-mode structure with the tanh joint ------------------------------------
def _modal_record(freq, volts, ks, xs, seconds=4.0, seed=0):
    """tests/test_modal_model.py's lap-jointed two-mass cantilever on its shaker (voltage
    drive, accelerations measured), its joint k_j d + k_s x_s tanh(d / x_s) with
    d = x_tip - x_root, integrated by DOP853 (its generator, this joint law); the record and
    the largest |d| after 1.5 s."""
    from test_modal_model import FS, _record

    rec, d = _record(freq, volts, 0.0, seconds=seconds, seed=seed, with_relative=True,
                     joint=lambda d: ks * xs * np.tanh(d / xs))
    t = np.arange(d.size) / FS
    return rec, float(np.max(np.abs(d[t > 1.5])))


def _mode1_reading(ks, xs):
    """The joint's tanh term seen on mode 1's coordinate q (the tip's mode-1 displacement,
    unit modal mass): d = r q, generalised force r F(r q) / m, i.e. k_s' = r^2 k_s / m and
    x_s' = x_s / r with r = 1 - phi_root / phi_tip; and w_1^2."""
    from test_modal_model import _matrices

    M, _, K = _matrices()
    L = np.linalg.cholesky(M)
    w2, V = np.linalg.eigh(np.linalg.inv(L) @ K @ np.linalg.inv(L).T)
    phi = np.linalg.solve(L.T, V[:, 0])
    phi = phi / phi[1]
    m, r = phi @ M @ phi, 1 - phi[0]
    return r * r * ks / m, xs / r, w2[0]


@pytest.mark.slow
def test_modal_fit_recovers_the_saturating_joint_within_10_percent():
    from test_modal_model import KJ, _basis

    from labjoint.compare.kinds.modal_prepare import prepare_modal
    from labjoint.compare.kinds.modal_fit import fit_modal

    ks, xs = 0.3 * KJ, 2e-5
    basis, modes = _basis()
    f1 = modes[0]["frequency_hz"]
    recs, peaks = [], []
    for i, (f, v) in enumerate(((f1 / 2, 0.1), (0.8 * f1, 0.2), (0.95 * f1, 0.3),
                                (1.1 * f1, 1.0), (f1 / 2, 1.0), (0.9 * f1, 1.5))):
        rec, d = _modal_record(f, v, ks, xs, seed=i)
        recs.append(prepare_modal(rec, basis, ["tip"], warmup_s=1.5, judge_s=0.5))
        peaks.append(d)
    assert min(peaks) < 0.5 * xs and max(peaks) > 10 * xs, peaks
    fit = fit_modal("linear_stiffness+viscous+saturating_stiffness", recs)
    want_ks, want_xs, w1sq = _mode1_reading(ks, xs)
    p = {k: v.value for k, v in fit.params_.items()}
    got = p["saturating_stiffness.k_s"] / p["linear_stiffness.k"]
    assert got == pytest.approx(want_ks / w1sq, rel=0.10)
    assert p["saturating_stiffness.x_s"] == pytest.approx(want_xs, rel=0.10)


def test_cli_fits_the_modal_kind_with_the_saturating_joint(tmp_path, capsys):
    """`labjoint fit RUN --modal modes.json --model linear_stiffness+viscous+saturating_stiffness`
    runs, and with the joint's law brings the tip's response to the noise (the root
    sensor, which the joint drives through mode 2, is left out as in test_modal_model)."""
    import json

    from test_modal_model import FS, KJ, _basis

    from labjoint.cli.main import main
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.csv_import import store_channels

    _, modes = _basis()
    rec, _ = _modal_record(0.9 * modes[0]["frequency_hz"], 1.0, 0.3 * KJ, 2e-5)
    spec = lambda n, q, u: ChannelSpec(n, "imported", q, u, 1.0, range_v=np.inf, coupling="DC")  # noqa: E731
    chans = [c for c in rec.channels.values() if c.name != "root"]
    path = store_channels(tmp_path / "x.h5", rec.time, FS,
                          [(spec(c.name, c.quantity, c.units), c.samples) for c in chans],
                          {"frequency_hz": rec.metadata["frequency_hz"], "drive_channels": ["input_V"],
                           "response_channels": ["tip"]}, tmp_path / "data", name="s1")
    mfile = tmp_path / "modes.json"
    mfile.write_text(json.dumps({"levels": [{"level": 1.0, "modes": modes}]}))
    rc = main(["fit", str(path), "--modal", str(mfile), "--model",
               "linear_stiffness+viscous+saturating_stiffness", "--json"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    d = json.loads(out.out)
    vals = {k: v["value"] for k, v in d["parameters"].items()}
    assert np.isfinite(vals["saturating_stiffness.k_s"]) and vals["saturating_stiffness.x_s"] > 0
    assert d["nrmse"] < 3e-3            # the linear model: 2.0 %


@pytest.mark.slow
def test_simulation_error_diagnosis_names_the_saturating_stiffness_along_records():
    """The same three records: the simulation-error diagnosis (`--kind record --error
    simulation`) adds saturating_stiffness, not a cubic spring nor a slider (20 s)."""
    from labjoint.compare.simulation_loop import diagnose_simulation

    runs = [_random_record(lv, i, fs=1000.0) for i, lv in enumerate((0.05, 0.5, 5.0))]
    d = diagnose_simulation(runs, "inertia+viscous+linear_stiffness", warmup=0.2,
                            candidates=["cubic_stiffness", "saturating_stiffness", "coulomb"])
    assert d.best is not None and d.best.effect == "saturating_stiffness", d.verdict
    cubic = next(c for c in d.candidates if c.effect == "cubic_stiffness")
    assert d.best.fit.nrmse("validation") < 0.2 * cubic.fit.nrmse("validation")
    p = d.best.fit.params
    assert p["saturating_stiffness.k_s"].value == pytest.approx(TRUE_SDOF["ks"], rel=0.05)
    assert p["saturating_stiffness.x_s"].value == pytest.approx(TRUE_SDOF["xs"], rel=0.05)


def test_structure_joint_law_takes_it_through_the_batched_steady_kernel():
    """At structure level (harmonic balance's batched periodic force): the law is a term of
    the kernel, odd (no normal part), and gives k u + k_s x_s tanh(u / x_s) on every row."""
    from labjoint.structure.joint import ODD_EFFECTS
    from labjoint.structure.law import JointLaw

    law = JointLaw("linear_stiffness+saturating_stiffness",
                   {"linear_stiffness.k": K, "saturating_stiffness.k_s": KS,
                    "saturating_stiffness.x_s": XS})
    assert law.kernel_terms is not None and "saturating_stiffness" in ODD_EFFECTS
    n = 64
    t = np.arange(n) / n
    u = np.stack([a * np.sin(2 * np.pi * t) for a in (0.5 * XS, 5 * XS, 50 * XS)])
    F = law.periodic(u, np.zeros_like(u), np.zeros_like(u), float(n))
    assert np.allclose(F, K * u + tanh_force(u), rtol=1e-12, atol=1e-12 * K * XS)
