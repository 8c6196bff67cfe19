"""The modal model driven through the electrodynamic shaker (issue 29 items 3, 5, 6), against
an independent generator written here: a two-mass lap-jointed cantilever (root mass on the
clamp's spring, tip mass joined to it by the joint) driven at the tip through a shaker
whose coil (R, L, Bl, back-EMF) and armature (m_a, k_a, c_a) are integrated with it by
scipy's DOP853; a voltage drive, no force measured, the tip's acceleration recorded. The
modes file is the loaded structure's linear modes (what a lab measures per volt)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import eig

from labjoint.cli.main import main
from labjoint.compare.kinds.modal import ModalSetup
from labjoint.compare.kinds.modal_prepare import _drive_end, prepare_modal
from labjoint.compare.kinds.modal_fit import fit_modal
from labjoint.errors import InputError
from labjoint.storage.channels import Channel, ChannelRecord
from labjoint.structure.nlmode import ModalBasis
from labjoint.structure.nlmode_shaker import ShakerPath

FS = 512.0
M1, M2 = 0.3, 0.2                        # root, tip (kg)
K1, KJ = 2.0e5, 5.0e3                    # clamp spring, joint (N/m)
SHAKER = {"force_factor_n_per_a": 2.0, "coil_resistance_ohm": 3.0, "coil_inductance_h": 2.0e-3,
          "armature_mass_kg": 0.02, "suspension_stiffness_n_per_m": 300.0,
          "suspension_damping_ns_per_m": 1.0, "amplifier_gain_v_per_v": 1.0}
BL, R, L, MA, KA, CA, G = (SHAKER[k] for k in SHAKER)


def _structure():
    M = np.diag([M1, M2])
    K = np.array([[K1 + KJ, -KJ], [-KJ, KJ]])
    return M, 1e-4 * K + 4.0 * M, K


def _record(freq, volts, k2=0.0, seconds=3.0, noise=2e-4, seed=0):
    """Tip acceleration (and the true force on the structure) under V = volts sin(2 pi f t)."""
    M, C, K = _structure()
    Mt = M + np.diag([0.0, MA])
    Ct = C + np.diag([0.0, CA])
    Kt = K + np.diag([0.0, KA])
    Mi = np.linalg.inv(Mt)
    w = 2 * np.pi * freq

    def rhs(t, s):
        x, v, i = s[:2], s[2:4], s[4]
        d = x[1] - x[0]
        fj = k2 * d * d
        f = np.array([fj, BL * i - fj])
        di = (G * volts * np.sin(w * t) - R * i - BL * v[1]) / L
        return np.r_[v, Mi @ (f - Ct @ v - Kt @ x), di]

    t = np.arange(int(seconds * FS)) / FS
    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(5), t_eval=t, method="DOP853", rtol=1e-9, atol=1e-12)
    acc = np.array([rhs(ti, si)[2:4] for ti, si in zip(t, sol.y.T)])
    x2, v2, i = sol.y[1], sol.y[3], sol.y[4]
    force = BL * i - MA * acc[:, 1] - CA * v2 - KA * x2
    rng = np.random.default_rng(seed)
    a = acc[:, 1]
    chans = {"input_V": Channel("input_V", volts * np.sin(w * t), "voltage", "V", "drive"),
             "tip": Channel("tip", a + noise * a.std() * rng.standard_normal(a.size), "acceleration",
                            "m/s^2", "response")}
    return ChannelRecord(f"s{freq:.4g}", t, FS, chans, {"frequency_hz": freq}), force, a


def _modes():
    """The loaded structure's linear modes (armature on the tip, back-EMF damping)."""
    M, C, K = _structure()
    M, K, C = M + np.diag([0, MA]), K + np.diag([0, KA]), C + np.diag([0, CA + BL**2 / R])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam, vec = eig(A)
    out = []
    for i in sorted(np.argsort(np.abs(lam))[::2], key=lambda i: abs(lam[i])):
        wn = abs(lam[i])
        shape = vec[:2, i] / vec[1, i]
        out.append({"frequency_hz": wn / (2 * np.pi), "damping_ratio": -lam[i].real / wn,
                    "shape": {"tip": [float(shape[1].real), 0.0], "root": [float(shape[0].real), 0.0]}})
    return out


def _mode1_structure():
    """Mode 1 of the structure alone: its modal mass at the tip (kg) and w^2."""
    M, _, K = _structure()
    w2, V = eig(K, M)
    i = int(np.argmin(w2.real))
    phi = V[:, i].real / V[1, i].real
    return float(phi @ M @ phi), float(w2[i].real)


def _setup(given, modal_mass=None):
    modes = _modes()
    basis = ModalBasis.from_dict({"reference": "tip", "modes": modes})
    path = ShakerPath.of(given, "tip", basis, modal_mass)
    f1 = modes[0]["frequency_hz"]
    recs = [_record(f, v, seed=i) for i, (f, v) in enumerate(((0.5 * f1, 1.0), (0.9 * f1, 0.3), (1.1 * f1, 0.3)))]
    from dataclasses import replace
    ms = [replace(prepare_modal(r, basis, ["tip"], warmup_s=1.5, judge_s=0.5),
                  setup=ModalSetup(bounds=(("shaker.highpass_hz", (0.0, 0.0)),), shaker=path))
          for r, _, _ in recs]
    return basis, path, ms, recs


@pytest.fixture(scope="module")
def fitted():
    given = {k: v for k, v in SHAKER.items()}
    basis, path, ms, recs = _setup(given)
    fit = fit_modal("linear_stiffness+viscous", ms)
    return basis, path, ms, recs, fit


def test_modal_mass_identified_through_the_shaker(fitted):
    """Every shaker parameter given: the records fix mode 1's modal mass at the drive point
    (the structure's, not the loaded one) and the structure's own stiffness; the responses
    to the noise."""
    _, path, _, _, fit = fitted
    m_d, w2 = _mode1_structure()
    assert path.free == "mode1.mass_kg"
    assert fit.params_["mode1.mass_kg"].value == pytest.approx(m_d, rel=0.01)
    assert fit.params_["linear_stiffness.k"].value == pytest.approx(w2, rel=0.01)
    assert fit.params_["shaker.highpass_hz"].value == 0.0 and "shaker.highpass_hz" not in fit.varied_
    assert fit.nrmse_ < 5e-3


def test_per_newton_prediction_against_the_generators_force(fitted):
    """The force on the structure the model gives (H2) and the tip's per-newton FRF at each
    sine's fundamental match the generator's within 3 %."""
    from labjoint.compare.modal_api import per_newton

    _, _, ms, recs, fit = fitted
    vals = fit.params_.valuesdict()
    for m, (rec, force, acc) in zip(ms, recs):
        q = m.states(fit.model, vals)
        out = per_newton(m, q, m.responses(fit.model, vals, q))
        f = m.frequency_hz
        end = _drive_end(rec.channels["input_V"].samples, FS)
        seg0 = end - m.drive.n + m.judged.start
        t = np.arange(m.judged.stop - m.judged.start) / FS
        e = np.exp(-2j * np.pi * f * t)
        sl = slice(seg0, seg0 + t.size)
        F_true = 2 * np.mean(force[sl] * e)
        A_true = 2 * np.mean(acc[sl] * e)
        fund = out["fundamental"]
        assert np.sqrt(np.mean(np.square(out["force_on_structure_n"]))) == pytest.approx(
            abs(F_true) / np.sqrt(2), rel=0.03)
        assert fund["channels"]["tip"]["per_newton"]["amplitude"] == pytest.approx(abs(A_true / F_true), rel=0.03)


def test_per_newton_model_predicts_a_force_driven_record(fitted):
    """The model fitted through the shaker on voltage records, run on a record driven by the
    generator's force on the structure (the structure alone, every mode per newton):
    the tip's acceleration within 2 %."""
    from dataclasses import replace

    basis, path, ms, recs, fit = fitted
    rec, force, _ = _record(0.7 * basis.modes[0].frequency_hz, 0.5, seed=9)
    chans = {"force": Channel("force", force, "force", "N", "drive"), "tip": rec.channels["tip"]}
    frec = ChannelRecord("by_force", rec.time, FS, chans, rec.metadata)
    m = replace(prepare_modal(frec, basis, ["tip"], warmup_s=1.5, judge_s=0.5), setup=ModalSetup(shaker=path))
    e = m.predict(fit.model, fit.params_) - m.data.force
    assert np.sqrt(np.mean(e**2) / np.mean(m.data.force**2)) < 0.02


def test_free_coil_resistance_recovered():
    """Bl, the armature and mode 1's modal mass given: R is what the records determine."""
    m_d, _ = _mode1_structure()
    given = {k: v for k, v in SHAKER.items() if k != "coil_resistance_ohm"}
    _, path, ms, _, = _setup(given, modal_mass=m_d)[:4]
    assert path.free == "shaker.coil_resistance_ohm"
    fit = fit_modal("linear_stiffness+viscous", ms)
    assert fit.params_["shaker.coil_resistance_ohm"].value == pytest.approx(R, rel=0.03)


def test_unidentifiable_shaker_parameters_refused_by_name():
    basis = ModalBasis.from_dict({"reference": "tip", "modes": _modes()})
    no_arm = {k: v for k, v in SHAKER.items() if k != "armature_mass_kg"}
    with pytest.raises(InputError, match="not identifiable without a force") as e:
        ShakerPath.of(no_arm, "tip", basis)
    assert e.value.field == "shaker.armature_mass_kg"
    two = {k: v for k, v in SHAKER.items() if k not in ("force_factor_n_per_a", "coil_resistance_ohm")}
    with pytest.raises(InputError, match="two of Bl, R") as e:
        ShakerPath.of(two, "tip", basis, 0.2)
    assert e.value.field == "shaker.force_factor_n_per_a"
    with pytest.raises(InputError, match="not a sensor of the modes") as e:
        ShakerPath.of(SHAKER, "hub", basis)
    assert e.value.field == "drive_point"


def _files(tmp_path, n=4):
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.csv_import import store_channels

    modes = _modes()
    f1 = modes[0]["frequency_hz"]
    spec = lambda n, q, u: ChannelSpec(n, "imported", q, u, 1.0, range_v=np.inf, coupling="DC")  # noqa: E731
    paths = []
    for i, (f, v) in enumerate(((0.5 * f1, 1.0), (0.9 * f1, 0.3), (1.1 * f1, 0.3), (0.7 * f1, 0.5))[:n]):
        rec = _record(f, v, seed=i, seconds=5.0)[0]
        paths.append(str(store_channels(
            tmp_path / f"r{i}.h5", rec.time, FS,
            [(spec(c.name, c.quantity, c.units), c.samples) for c in rec.channels.values()],
            {"frequency_hz": f, "drive_channels": ["input_V"], "response_channels": ["tip"]},
            tmp_path / "data", name=f"s{i}")))
    mfile = tmp_path / "modes.json"
    mfile.write_text(json.dumps({"levels": [{"level": 1.0, "modes": modes}]}))
    sfile = tmp_path / "shaker.toml"
    sfile.write_text("[shaker]\n" + "".join(f"{k} = {v!r}\n" for k, v in SHAKER.items()))
    return paths, str(mfile), str(sfile)


def test_cli_start_outside_bounds_refused_in_one_line(tmp_path, capsys):
    paths, mfile, _ = _files(tmp_path, 1)
    out = tmp_path / "m.json"
    rc = main(["fit", paths[0], "--modal", mfile, "--model", "linear_stiffness+viscous", "--json",
               "--start", "viscous.c=5", "--bound", "viscous.c=0:1", "--out", str(out)])
    err = capsys.readouterr()
    assert rc == 2 and err.out == "" and not out.exists()
    assert "start.viscous.c" in err.err and "outside the bounds" in err.err and err.err.count("\n") == 1
    rc = main(["fit", paths[0], "--modal", mfile, "--model", "linear_stiffness+viscous", "--json",
               "--start", "modal.phi1.tip=1"])
    err = capsys.readouterr()
    assert rc == 2 and "start.modal.phi1.tip" in err.err


@pytest.mark.slow
def test_cli_fit_with_shaker_saves_it_and_predict_prints_both(tmp_path, capsys):
    paths, mfile, sfile = _files(tmp_path)
    out = tmp_path / "m.json"
    rc = main(["fit", *paths[:3], "--modal", mfile, "--model", "linear_stiffness+viscous", "--json",
               "--shaker", sfile, "--drive-point", "tip", "--bound", "shaker.highpass_hz=0:0",
               "--start", "viscous.c=8", "--out", str(out)])
    res = json.loads(capsys.readouterr().out)
    assert rc == 0 and "electrodynamic shaker" in res["drive_path"] and "no high-pass" in res["drive_path"]
    saved = json.loads(out.read_text())
    assert saved["shaker"]["fitted"] == "mode1.mass_kg"
    assert saved["shaker"]["mode1_mass_kg"] == pytest.approx(_mode1_structure()[0], rel=0.05)
    rc = main(["predict", str(out), paths[3], "--json"])
    res = json.loads(capsys.readouterr().out)
    assert rc == 0 and res["nrmse"] < 0.02
    tip = res["fundamental"]["channels"]["tip"]
    assert tip["per_volt"]["amplitude"] > 0 and tip["per_newton"]["amplitude"] > 0


@pytest.mark.slow
def test_even_joint_named_first_through_the_shaker():
    """A quadratic joint stiffness behind the shaker: diagnose (the shaker given, the modal
    mass fitted with the joint) names the even effect first and the response NRMSE falls."""
    from dataclasses import replace

    from labjoint.compare.diagnosis import DiagnoseSettings, diagnose_prepared

    modes = _modes()
    basis = ModalBasis.from_dict({"reference": "tip", "modes": modes})
    path = ShakerPath.of(SHAKER, "tip", basis)
    f1 = modes[0]["frequency_hz"]
    setup = ModalSetup(bounds=(("shaker.highpass_hz", (0.0, 0.0)),), shaker=path)
    ms = [replace(prepare_modal(_record(f, v, k2=3e6, seed=i)[0], basis, ["tip"], warmup_s=1.5, judge_s=0.5),
                  setup=setup)
          for i, (f, v) in enumerate(((f1 / 2, 2.0), (0.8 * f1, 1.0), (0.95 * f1, 0.5), (1.1 * f1, 1.0),
                                      (f1 / 2, 1.0), (0.9 * f1, 0.8)))]
    dg = diagnose_prepared(ms, "linear_stiffness+viscous",
                           settings=DiagnoseSettings(candidates=("quadratic_stiffness", "cubic_stiffness")))
    assert dg.candidates[0].effect == "quadratic_stiffness"
    assert dg.candidates[0].nrmse_after < 0.5 * dg.nrmse
