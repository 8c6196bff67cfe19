"""Forward prediction and identification by simulation error (issue 14 item 3).

The simulator is checked against the closed-form steady state of a linear oscillator and
against the force balance of the joint laws along the response it computes; the output-
error fit must recover the parameters of a simulated Bouc-Wen oscillator from a noisy
multisine record with no user guess, and predict a multisine it was not fitted on.
"""

import json

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.compare.model_file import load_model
from labjoint.compare.output_error import fit_simulation
from labjoint.errors import InputError
from labjoint.models import Model, ModelInputs
from labjoint.models.simulate import simulate
from labjoint.storage import Run

FS = 750.0
N = 1024                                   # samples per period: lines every 0.73 Hz
LINEAR = {"inertia.m": 2.0, "viscous.c": 10.0, "linear_stiffness.k": 5e4}
#: the Bouc-Wen benchmark's system (a hardening law: alpha + beta < 0)
BW = {**LINEAR, "bouc_wen.k0": 5e4, "bouc_wen.alpha": 800.0, "bouc_wen.beta": -1100.0,
      "bouc_wen.n": 1.0}
#: a saturating law: (k0 / (alpha + beta))^(1/n) = 40 N
SOFT = {**LINEAR, "bouc_wen.k0": 3e4, "bouc_wen.alpha": 71.15, "bouc_wen.beta": 47.43,
        "bouc_wen.n": 1.5}
EXPR = "inertia+viscous+linear_stiffness+bouc_wen"


def multisine(seed, periods=1, rms=50.0, n=N):
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, 1 / FS)
    sel = (f >= 5) & (f <= 150)
    spec = np.zeros(f.size, complex)
    spec[sel] = np.exp(2j * np.pi * rng.random(sel.sum()))
    u = np.fft.irfft(spec, n)
    return np.tile(u * rms / np.std(u), periods)


def test_a_linear_oscillator_reaches_its_closed_form_steady_state():
    k_line = 41                                   # an integer number of cycles per record
    t = np.arange(N) / FS
    w = 2 * np.pi * k_line * FS / N
    F = 50.0 * np.sin(w * t)
    y = simulate("inertia+viscous+linear_stiffness", LINEAR, F, FS, periodic=True)
    H = 1.0 / (LINEAR["linear_stiffness.k"] - LINEAR["inertia.m"] * w ** 2 + 1j * LINEAR["viscous.c"] * w)
    expected = np.imag(50.0 * H * np.exp(1j * w * t))
    assert np.max(np.abs(y - expected)) < 1e-6 * np.max(np.abs(expected))


@pytest.mark.parametrize("expr, params", [
    (EXPR, SOFT),
    ("inertia+viscous+linear_stiffness+coulomb", {**LINEAR, "coulomb.k": 3e4, "coulomb.f_s": 20.0}),
])
def test_the_simulated_response_balances_the_force_through_every_joint_law(expr, params):
    """m a + c v + k y + z(y history) = F along the simulated y (the models layer's own
    evaluation of each law, with the response's exact spectral derivatives)."""
    F = multisine(3)
    y = simulate(expr, params, F, FS, periodic=True)
    spec = np.fft.rfft(y)
    jw = 2j * np.pi * np.fft.rfftfreq(N, 1 / FS)
    v, a = np.fft.irfft(spec * jw, N), np.fft.irfft(spec * jw * jw, N)
    # three periods of the periodic response so every hysteretic state is steady
    inp = ModelInputs(np.tile(y, 3), np.tile(v, 3), np.tile(a, 3), FS)
    balance = Model.parse(expr).eval(params, inp)[-N:]
    # the laws along the samples against the simulator's 20x sub-steps: 1 % at 5 samples
    # per period of the top line (a wrong law or sign is tens of %)
    assert np.sqrt(np.mean((balance - F) ** 2)) < 1e-2 * np.std(F)


def _record(name, F, params=BW, noise=1e-6, seed=5):
    y = simulate(EXPR, params, F, FS)
    y = y + noise * np.random.default_rng(seed).standard_normal(y.size)
    return Run(name, np.arange(F.size) / FS, y, F, {"sample_rate_hz": FS})


def test_output_error_recovers_a_bouc_wen_oscillator_and_predicts_a_new_multisine():
    fit = fit_simulation([_record("train", multisine(1, periods=4))], EXPR)
    for k, v in BW.items():
        assert fit.params[k].value == pytest.approx(v, rel=0.02), k
        assert abs(fit.params[k].value - v) < 5 * fit.stderr[k] + 1e-3 * abs(v), k
    assert fit.nrmse() < 2 * fit.noise_floor()
    from labjoint.compare.kinds import prepare
    from labjoint.compare.output_error import predict_record
    test = Run("test", np.arange(N) / FS, simulate(EXPR, BW, multisine(9), FS, periodic=True),
               multisine(9), {"sample_rate_hz": FS})
    m = prepare([test], kind="record", warmup=0)[0]
    pred = predict_record(fit.model, fit.params, m, periodic=True)
    assert pred.nrmse < 5e-3


def _csv(path, run):
    rows = "\n".join(f"{t!r},{y!r},{f!r}" for t, y, f in zip(run.time.tolist(),
                                                           run.displacement.tolist(), run.force.tolist()))
    path.write_text("time_s,displacement_m,force_N\n" + rows + "\n")
    return path


def test_cli_fit_by_simulation_saves_a_model_that_predict_runs(tmp_path, capsys):
    train = _csv(tmp_path / "train.csv", _record("train", multisine(1, periods=4),
                                                 params=LINEAR | {"bouc_wen.k0": 1.0,
                                                                  "bouc_wen.alpha": 0.5,
                                                                  "bouc_wen.beta": 0.5,
                                                                  "bouc_wen.n": 1.0}))
    model = tmp_path / "model.json"
    assert main(["fit", str(train), "--model", "inertia+viscous+linear_stiffness",
                 "--error", "simulation", "--out", str(model), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["error"] == "simulation" and res["saved"] == str(model)
    assert res["parameters"]["inertia.m"]["value"] == pytest.approx(2.0, rel=0.01)
    saved = json.loads(model.read_text())
    assert saved["model"] == "inertia+viscous+linear_stiffness" and saved["structure"] == "sdof"
    F = multisine(9)
    y = simulate("inertia+viscous+linear_stiffness", LINEAR, F, FS, periodic=True)
    test = _csv(tmp_path / "test.csv", Run("t", np.arange(N) / FS, y, F, {"sample_rate_hz": FS}))
    out = tmp_path / "pred.csv"
    assert main(["predict", str(model), str(test), "--periodic", "--out", str(out), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["rmse"] < 1e-2 * np.std(y) and res["nrmse"] < 1e-2
    assert res["samples"] == N                   # one steady period: every sample judged
    lines = out.read_text().splitlines()
    assert lines[0] == "time_s,displacement_m,predicted_m" and len(lines) == N + 1


def test_models_that_cannot_be_simulated_and_bad_model_files_are_refused(tmp_path, capsys):
    with pytest.raises(InputError, match="needs a mass"):
        simulate("viscous+linear_stiffness", {"viscous.c": 1.0, "linear_stiffness.k": 1.0},
                 np.ones(10), FS)
    with pytest.raises(InputError, match="not \\['iwan'\\]"):
        simulate("inertia+iwan", {}, np.ones(10), FS)
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "something else"}')
    with pytest.raises(InputError, match="not a labjoint model file"):
        load_model(bad)
    assert main(["predict", str(bad), str(bad), "--json"]) == 2
    assert "not a labjoint model file" in capsys.readouterr().err
