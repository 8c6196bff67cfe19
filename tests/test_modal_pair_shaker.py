"""The joint between two measured points driven through the electrodynamic shaker (issue 29
items 3 and 5) against an independent generator written here: a 3-mass chain with a cubic
spring between masses 2 and 3, a shaker at mass 1 whose coil (R, L, Bl, back-EMF) and
armature (m_a, k_a, c_a) are integrated with it by scipy's Radau in physical coordinates
(no modal reduction, no labjoint law); a voltage drive, no force measured. The modal model
gets what a per-volt modal test measures: the linear modes of the chain with the shaker
attached (armature, suspension, back-EMF), frequencies, damping ratios and shapes
relative to the reference sensor s2. The chain's own damping is chosen so that, with the
shaker's damping at mass 1, the loaded damping is modal: the measured modes are then
exact and what is tested is the shaker's coupling."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import eigh

from labjoint.compare.kinds.modal import ModalSetup
from labjoint.compare.kinds.modal_prepare import prepare_modal
from labjoint.errors import InputError
from labjoint.storage.channels import Channel, ChannelRecord
from labjoint.structure.nlmode import ModalBasis
from labjoint.structure.nlmode_shaker import ShakerPath

M = np.diag([1.0, 0.6, 0.4])
K = np.array([[3e4, -1e4, 0.0], [-1e4, 1.8e4, -8e3], [0.0, -8e3, 8e3]])
ZETA = np.array([0.02, 0.015, 0.01])        # the loaded chain's modal damping
K3 = 2e9                                    # the joint between masses 2 and 3: F = k3 u^3
SHAKER = {"force_factor_n_per_a": 4.0, "coil_resistance_ohm": 4.0, "coil_inductance_h": 0.0,
          "armature_mass_kg": 0.05, "suspension_stiffness_n_per_m": 800.0,
          "suspension_damping_ns_per_m": 0.3, "amplifier_gain_v_per_v": 20.0}
BL, R, _, MA, KA, CA, G = (SHAKER[k] for k in SHAKER)
COIL_L = 2.0e-5                             # H: the slow tests' coil (corner 32 kHz), left out by the model
FS, T = 400.0, 6.0
TONES = ((4.0, 0.6, 0.3), (11.0, 0.5, 1.1), (19.0, 0.3, 2.0))   # f (Hz), amplitude (V), phase
E1 = np.diag([1.0, 0.0, 0.0])


def volts(t):
    return sum(a * np.sin(2 * np.pi * f * t + p) - a * np.sin(p) * np.exp(-t) for f, a, p in TONES)


def _loaded():
    """The chain with the shaker attached: mass, stiffness, its modes (mass-normalised)
    and the loaded damping (modal, ZETA)."""
    Ml, Kl = M + MA * E1, K + KA * E1
    w2, phi = eigh(Kl, Ml)
    Cl = Ml @ phi @ np.diag(2 * ZETA * np.sqrt(w2)) @ phi.T @ Ml
    return Ml, Kl, Cl, w2, phi


def _generate(scale: float, joint: bool = True, inductance: float = 0.0):
    """(t, x, a, force on the structure at mass 1) under scale x volts(t); the coil's
    current a state with ``inductance`` > 0 (Radau: its time constant is microseconds),
    else R i = G V - Bl x1' (DOP853)."""
    Ml, Kl, Cl, _, _ = _loaded()
    C = Cl - (CA + BL * BL / R) * E1            # the chain's own damping (the shaker's beside)
    Mt = M + MA * E1                            # the armature moves with mass 1
    Mi = np.linalg.inv(Mt)
    Kt, Ct = K + KA * E1, C + CA * E1

    def current(t, s):
        return s[6] if inductance else (G * scale * volts(t) - BL * s[3]) / R

    def rhs(t, s):
        x, v = s[:3], s[3:6]
        f = np.array([BL * current(t, s), 0.0, 0.0])
        if joint:
            u = x[1] - x[2]
            f += np.array([0.0, -K3 * u ** 3, K3 * u ** 3])
        out = np.r_[v, Mi @ (f - Ct @ v - Kt @ x)]
        if inductance:
            out = np.r_[out, (G * scale * volts(t) - R * s[6] - BL * v[0]) / inductance]
        return out

    def jac(t, s):
        J = np.zeros((7, 7))
        J[:3, 3:6] = np.eye(3)
        Kx = Kt.copy()
        if joint:
            Kx += 3 * K3 * (s[1] - s[2]) ** 2 * np.array([[0, 0, 0], [0, 1, -1], [0, -1, 1]])
        J[3:6, :3] = -Mi @ Kx
        J[3:6, 3:6] = -Mi @ Ct
        J[3:6, 6] = Mi @ np.array([BL, 0.0, 0.0])
        J[6, 3], J[6, 6] = -BL / inductance, -R / inductance
        return J

    t = np.arange(int(T * FS)) / FS
    n = 7 if inductance else 6
    kw = dict(method="Radau", jac=jac, rtol=1e-8, atol=1e-12) if inductance else \
        dict(method="DOP853", rtol=1e-11, atol=1e-14)
    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(n), t_eval=t, **kw)
    acc = np.array([rhs(ti, si)[3:6] for ti, si in zip(t, sol.y.T)])
    x, v = sol.y[:3].T, sol.y[3:6].T
    i = np.array([current(ti, si) for ti, si in zip(t, sol.y.T)])
    force = BL * i - MA * acc[:, 0] - CA * v[:, 0] - KA * x[:, 0]
    return t, x, acc, force


def _basis_and_truth():
    """What the modal test measures (reference s2) and the parameters it implies."""
    _, _, _, w2, phi = _loaded()
    ref = phi[1]
    modes = [{"frequency_hz": float(np.sqrt(w2[j]) / (2 * np.pi)), "damping_ratio": float(ZETA[j]),
              "shape": {f"s{i + 1}": float(phi[i, j] / ref[j]) for i in range(3)}} for j in range(3)]
    basis = ModalBasis.from_dict({"reference": "s2", "modes": modes})
    M1 = 1.0 / ref[0] ** 2                               # mode 1's modal mass (reference-normalised)
    phi_d1 = phi[0, 0] / ref[0]
    truth = {"cubic_stiffness.k3": K3 / M1, "mode1.mass_kg": M1 / phi_d1 ** 2 - MA}
    for j in (1, 2):
        truth[f"modal.mass{j + 1}"] = ref[0] ** 2 / ref[j] ** 2
    return basis, modes, truth


def _record(scale: float, name: str, seed: int = 0, inductance: float = 0.0):
    t, x, a, _ = _generate(scale, inductance=inductance)
    rng = np.random.default_rng(seed)
    chans = {"v": Channel("v", scale * volts(t), "voltage", "V", "drive")}
    for nm, qty, y, unit in (("s1", "acceleration", a[:, 0], "m/s^2"), ("s2", "displacement", x[:, 1], "m"),
                             ("s3", "acceleration", a[:, 2], "m/s^2")):
        chans[nm] = Channel(nm, y + 1e-4 * y.std() * rng.standard_normal(y.size), qty, unit, "response")
    return ChannelRecord(name, t, FS, chans, {})


def _given(*drop: str) -> dict[str, float]:
    return {k: v for k, v in SHAKER.items() if k not in drop}


def _measurement(rec, basis, given, modal_mass=None):
    path = ShakerPath.of(given, "s1", basis, modal_mass)
    m = prepare_modal(rec, basis, between=("s2", "s3"))
    return replace(m, setup=ModalSetup(bounds=(("shaker.highpass_hz", (0.0, 0.0)),), shaker=path))


def _nrmse(m, r):
    return float(np.sqrt(np.mean((m - r) ** 2) / np.mean(r ** 2)))


def test_shaker_drives_every_mode_of_the_two_point_model():
    """With the true shaker, modal masses and law, the modal model's responses at every
    sensor and the force on the structure (P2) match the physical chain's; the joint
    matters, and the drive through the shaker is not a per-volt gain on mode 1 alone."""
    basis, _, truth = _basis_and_truth()
    rec = _record(1.0, "high")
    m = _measurement(rec, basis, _given(), truth["mode1.mass_kg"])
    vals = {**truth, "shaker.highpass_hz": 0.0}
    q = m.states("cubic_stiffness", vals)
    series = m.responses("cubic_stiffness", vals, q)
    t, x, a, force = _generate(1.0)
    for ch, y in (("s1", a[:, 0]), ("s2", x[:, 1]), ("s3", a[:, 2])):
        assert _nrmse(series[ch], y) < 3e-4, ch
    assert _nrmse(m.structure_force(q, vals), force) < 3e-4
    _, x_lin, _, _ = _generate(1.0, joint=False)
    assert _nrmse(x_lin[:, 1], x[:, 1]) > 0.05
    # mode 1 alone through the shaker (the others undriven) is far off
    d = m.setup.shaker.pair_drives(vals, basis)
    from labjoint.structure.nlmode_pair import pair_response, pair_states
    one = pair_states("cubic_stiffness", {**vals, **d, "modal.drive2": 0.0, "modal.drive3": 0.0}, basis,
                      ("s2", "s3"), m.drive)
    assert _nrmse(pair_response(one, basis, "s1", "acceleration"), a[:, 0]) > 0.1


def _store(tmp_path, rec):
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.csv_import import store_channels

    spec = lambda n, q, u: ChannelSpec(n, "imported", q, u, 1.0, range_v=np.inf, coupling="DC")  # noqa: E731
    return store_channels(tmp_path / f"{rec.name}.h5", rec.time, FS,
                          [(spec(c.name, c.quantity, c.units), c.samples) for c in rec.channels.values()],
                          {"drive_channels": ["v"], "response_channels": ["s1", "s2", "s3"]},
                          tmp_path / "data", name=rec.name)


def _files(tmp_path, modes, given):
    mfile = tmp_path / "modes.json"
    mfile.write_text(json.dumps({"levels": [{"level": 1.0, "modes": [
        {**m, "reference_sensor": "s2"} for m in modes]}]}))
    sfile = tmp_path / "shaker.toml"
    sfile.write_text("[shaker]\n" + "".join(f"{k} = {v!r}\n" for k, v in given.items()))
    return mfile, sfile


def test_two_point_shaker_refusals(tmp_path):
    """Refused by name, nothing fitted: the single mode's identifiability rules (armature;
    two of Bl, R and the modal mass), a drive point outside the modes, a coil whose corner
    is within 10x the highest mode, a force record through a per-volt shaker model."""
    from labjoint.compare.modal_api import load_modal

    basis, modes, truth = _basis_and_truth()
    rec = _record(0.5, "low")
    path = _store(tmp_path, rec)
    mfile, _ = _files(tmp_path, modes, _given())
    base = {"modal": str(mfile), "between": "s2,s3", "drive_point": "s1"}
    with pytest.raises(InputError) as e:
        load_modal([path], None, {**base, "shaker": _given("armature_mass_kg")})
    assert e.value.field == "shaker.armature_mass_kg"
    with pytest.raises(InputError) as e:
        load_modal([path], None, {**base, "shaker": _given("force_factor_n_per_a")})
    assert e.value.field == "shaker.force_factor_n_per_a"
    with pytest.raises(InputError) as e:
        load_modal([path], None, {**base, "drive_point": "s9", "shaker": _given()})
    assert e.value.field == "drive_point"
    ms, _ = load_modal([path], None, {**base, "shaker": _given()})       # Bl, R given: m_d fitted
    assert ms[0].between == ("s2", "s3") and ms[0].setup.shaker.free == "mode1.mass_kg"
    vals = {**truth, "shaker.highpass_hz": 0.0}
    slow_coil = _measurement(rec, basis, {**_given(), "coil_inductance_h": 5e-3}, truth["mode1.mass_kg"])
    with pytest.raises(InputError) as e:
        slow_coil.states("cubic_stiffness", vals)
    assert e.value.field == "shaker.coil_inductance_h" and "does not integrate" in e.value.message
    chans = dict(rec.channels)
    chans["v"] = Channel("v", chans["v"].samples, "force", "N", "drive")
    forced = _measurement(ChannelRecord("f", rec.time, FS, chans, {}), basis, _given(), truth["mode1.mass_kg"])
    with pytest.raises(InputError) as e:
        forced.states("cubic_stiffness", vals)
    assert e.value.field == "shaker" and "per volt" in e.value.message


@pytest.fixture(scope="module")
def coil_records():
    """Two levels of the chain with the coil's inductance integrated (Radau)."""
    return [_record(0.5, "low", 1, COIL_L), _record(1.0, "high", 2, COIL_L)]


@pytest.mark.slow
@pytest.mark.parametrize("free", ["mode1.mass_kg", "shaker.coil_resistance_ohm"])
def test_fit_through_the_shaker_recovers_the_joint_and_the_free_parameter(coil_records, free):
    """Fitted on one level through the shaker (the coil's lag in the data, left out by the
    model), validated on the other: the law, the relative modal masses and the one shaker
    parameter the records determine come back."""
    from labjoint.compare.kinds.modal_maps import MODAL

    basis, _, truth = _basis_and_truth()
    truth = {**truth, "shaker.coil_resistance_ohm": R}
    given = {**_given(), "coil_inductance_h": COIL_L}
    if free == "mode1.mass_kg":
        ms = [_measurement(r, basis, given) for r in coil_records]
    else:
        ms = [_measurement(r, basis, _given("coil_resistance_ohm") | {"coil_inductance_h": COIL_L},
                           truth["mode1.mass_kg"]) for r in coil_records]
    assert ms[0].setup.shaker.free == free
    fit = MODAL.fit("cubic_stiffness", ms[1:], ms[:1])
    v = fit.params_.valuesdict()
    assert fit.nrmse_ < 1e-3 and fit.validation_nrmse_ < 1e-3
    assert not any(k.startswith("modal.drive") for k in fit.varied_)
    for k in ("cubic_stiffness.k3", "modal.mass2", "modal.mass3", free):
        assert v[k] == pytest.approx(truth[k], rel=3e-3), k


@pytest.mark.slow
def test_cli_fit_between_through_the_shaker_then_predict(tmp_path, capsys, coil_records):
    """`fit --modal --between s2,s3 --shaker S.toml --drive-point s1 --out` on one level,
    then `predict` on the other: per volt and per newton, the force on the structure
    against the generator's."""
    from labjoint.cli.main import main

    basis, modes, truth = _basis_and_truth()
    mfile, sfile = _files(tmp_path, modes, {**_given(), "coil_inductance_h": COIL_L})
    low, high = (_store(tmp_path, r) for r in coil_records)
    out = tmp_path / "model.json"
    rc = main(["fit", str(high), "--modal", str(mfile), "--between", "s2,s3", "--shaker", str(sfile),
               "--drive-point", "s1", "--model", "cubic_stiffness", "--bound", "shaker.highpass_hz=0:0",
               "--out", str(out), "--json"])
    res = json.loads(capsys.readouterr().out)
    assert rc == 0 and res["nrmse"] < 2e-3
    assert res["parameters"]["mode1.mass_kg"]["value"] == pytest.approx(truth["mode1.mass_kg"], rel=1e-2)
    assert "every mode at s1" in res["drive_path"] and "between s2 and s3" in res["error"]
    saved = json.loads(out.read_text())
    assert saved["between"] == ["s2", "s3"] and saved["shaker"]["drive_point"] == "s1"
    rc = main(["predict", str(out), str(low), "--json", "--full"])
    pred = json.loads(capsys.readouterr().out)
    assert rc == 0 and pred["nrmse"] < 2e-3
    _, _, _, force = _generate(0.5, inductance=COIL_L)
    model_f = np.array(pred["force_on_structure_n"])
    assert _nrmse(model_f, force[:model_f.size]) < 5e-3


def test_diagnose_names_the_cubic_joint_behind_the_shaker(tmp_path):
    """`diagnose` of the linear model between s2 and s3 through the shaker, validated on
    the other level: cubic stiffness named first and significant, to the noise; the drive
    path says the shaker drives every mode."""
    import labjoint.compare as compare

    basis, _, _ = _basis_and_truth()
    paths = [str(_store(tmp_path, _record(s, n, seed=i))) for i, (s, n) in enumerate(((0.5, "low"), (1.0, "high")))]
    res = compare.diagnose(paths, "linear_stiffness", modal=basis, between=["s2", "s3"], shaker=_given(),
                           drive_point="s1", bounds={"shaker.highpass_hz": [0.0, 0.0]}, validate=[paths[0]],
                           candidates=["cubic_stiffness", "quadratic_stiffness", "viscous"])
    assert res["nrmse"] > 0.1 and not res["adequate"]
    first = res["candidates"][0]
    assert first["effect"] == "cubic_stiffness" and first["significant"]
    assert first["nrmse_after"] < 1e-3
    assert [c["effect"] for c in res["candidates"] if c["significant"]] == ["cubic_stiffness"]
    assert res["drive_path"].endswith("every mode at s1")
