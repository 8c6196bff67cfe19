"""The modal model of a structure nobody can describe (issue 29 items 2, 3, 5), against an
independent generator written here: a two-mass lap-jointed cantilever (root mass on the
clamp's spring, tip mass joined to it by the joint: k_j d + k_2 d^2, d = x_tip - x_root),
driven at the tip by an electrodynamic shaker on a voltage (coil R, Bl, back-EMF,
armature mass; no force measured), measured by acceleration at the tip (the root
accelerometer is in the modes; its response to the joint force through mode 2 is what a
single nonlinear mode leaves out, so it is not compared), integrated by scipy's DOP853.
The modes file is the generator's own linear modes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import eig

from labjoint.cli.main import main
from labjoint.compare.diagnosis import diagnose_prepared
from labjoint.compare.kinds.modal_prepare import prepare_modal
from labjoint.compare.kinds.modal_fit import fit_modal
from labjoint.errors import InputError
from labjoint.storage.channels import Channel, ChannelRecord
from labjoint.structure.nlmode import ModalBasis, QUANTITY_ORDER, shaker_identifiable

FS = 512.0
M1, M2, MA = 0.3, 0.2, 0.02           # root, tip, armature (kg)
K1, KJ = 2.0e5, 5.0e3                 # clamp spring, joint (N/m)
R, BL, G = 2.0, 0.5, 1.0              # coil ohm, force factor N/A, amplifier gain


def _matrices():
    M = np.diag([M1, M2 + MA])
    K = np.array([[K1 + KJ, -KJ], [-KJ, KJ]])
    C = 1e-4 * K + 4.0 * M                   # proportional (the back-EMF's Bl^2 / R added below)
    C[1, 1] += BL**2 / R
    return M, C, K


def _record(freq, volts, k2, seconds=4.0, noise=2e-4, seed=0, name=None, joint=None,
            with_relative=False):
    """Tip and root acceleration under G V = volts sin(2 pi f t) through the shaker; the
    joint's added force k2 d^2 (d = x_tip - x_root), or ``joint(d)``; ``with_relative``:
    (record, d at every sample)."""
    M, C, K = _matrices()
    Mi = np.linalg.inv(M)
    w = 2 * np.pi * freq

    def rhs(t, s):
        x, v = s[:2], s[2:]
        d = x[1] - x[0]
        fj = k2 * d * d if joint is None else joint(d)
        f = np.array([fj, BL * G * volts * np.sin(w * t) / R - fj])   # back-EMF in C
        return np.r_[v, Mi @ (f - C @ v - K @ x)]

    t = np.arange(int(seconds * FS)) / FS
    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(4), t_eval=t, method="DOP853", rtol=1e-8, atol=1e-12)
    acc = np.array([rhs(ti, si)[2:] for ti, si in zip(t, sol.y.T)])
    rng = np.random.default_rng(seed)
    chans = {"input_V": Channel("input_V", volts * np.sin(w * t), "voltage", "V", "drive")}
    for i, nm in ((1, "tip"), (0, "root")):
        a = acc[:, i]
        chans[nm] = Channel(nm, a + noise * a.std() * rng.standard_normal(a.size), "acceleration",
                            "m/s^2", "response")
    rec = ChannelRecord(name or f"s{freq:g}_{volts:g}", t, FS, chans, {"frequency_hz": freq})
    return (rec, sol.y[1] - sol.y[0]) if with_relative else rec


def _basis():
    M, C, K = _matrices()
    n = 2
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam, vec = eig(A)
    keep = np.argsort(np.abs(lam))[::2]
    modes = []
    for i in sorted(keep, key=lambda i: abs(lam[i])):
        wn = abs(lam[i])
        shape = vec[:n, i] / vec[1, i]
        modes.append({"frequency_hz": wn / (2 * np.pi), "damping_ratio": -lam[i].real / wn,
                      "shape": {"tip": [float(shape[1].real), 0.0], "root": [float(shape[0].real), 0.0]}})
    return ModalBasis.from_dict({"reference": "tip", "modes": modes}), modes


def _set(k2):
    basis, modes = _basis()
    f1 = modes[0]["frequency_hz"]
    recs = [_record(f, v, k2, seed=i) for i, (f, v) in
            enumerate(((f1 / 2, 1.0), (0.8 * f1, 0.5), (0.95 * f1, 0.25), (1.1 * f1, 0.5),
                       (f1 / 2, 0.5), (0.9 * f1, 0.4)))]
    return basis, [prepare_modal(r, basis, ["tip"], warmup_s=1.5, judge_s=0.5) for r in recs]


def _k2_modal(k2):
    """The joint's quadratic term seen on mode 1's coordinate (tip displacement, unit modal
    mass): F = k2 (r q)^2 acting along r, r = 1 - phi_root / phi_tip."""
    M, _, K = _matrices()
    w2, V = np.linalg.eigh(np.linalg.inv(np.linalg.cholesky(M)) @ K @ np.linalg.inv(np.linalg.cholesky(M)).T)
    phi = np.linalg.solve(np.linalg.cholesky(M).T, V[:, 0])
    phi = phi / phi[1]
    m = phi @ M @ phi
    r = 1 - phi[0]
    return k2 * r**3 / m, w2[0]


def test_linear_model_of_the_linear_beam_is_exact_from_the_states():
    """No joint nonlinearity: the modal model (measured modes, participations projected)
    reproduces both accelerations to the noise, with k = w_1^2."""
    basis, ms = _set(0.0)
    fit = fit_modal("linear_stiffness+viscous", ms[:3], ms[3:])
    w1 = 2 * np.pi * basis.modes[0].frequency_hz
    assert fit.params_["linear_stiffness.k"].value == pytest.approx(w1**2, rel=2e-3)
    assert fit.nrmse_ < 2e-3 and fit.validation_nrmse_ < 2e-3


@pytest.mark.slow
def test_even_joint_named_first_and_its_asymmetry_recovered():
    k2 = 3.0e6
    basis, ms = _set(k2)
    cands = ("quadratic_stiffness", "cubic_stiffness", "bilinear_stiffness")
    from labjoint.compare.diagnosis import DiagnoseSettings
    dg = diagnose_prepared(ms, "linear_stiffness+viscous", settings=DiagnoseSettings(candidates=cands))
    assert dg.candidates[0].effect == "quadratic_stiffness"
    assert dg.candidates[0].nrmse_after < dg.nrmse


@pytest.mark.slow
def test_even_joint_asymmetry_recovered_within_10_percent():
    k2 = 3.0e6
    basis, ms = _set(k2)
    fit = fit_modal("linear_stiffness+viscous+quadratic_stiffness", ms)
    want, w1sq = _k2_modal(k2)
    got = fit.params_["quadratic_stiffness.k2"].value / fit.params_["linear_stiffness.k"].value
    assert got == pytest.approx(want / w1sq, rel=0.10)


@pytest.mark.slow
def test_null_case_linear_joint_is_adequate():
    _, ms = _set(0.0)
    from labjoint.compare.diagnosis import DiagnoseSettings
    dg = diagnose_prepared(ms, "linear_stiffness+viscous",
                           settings=DiagnoseSettings(candidates=("quadratic_stiffness", "cubic_stiffness")))
    assert dg.adequate


def test_responses_exactly_in_the_measured_quantity():
    """Velocity and acceleration of the model are the states' own: for a linear mode under a
    sine, the acceleration is -w^2 x the displacement in steady state (closed form)."""
    basis, _ = _basis()
    rec = _record(5.0, 1.0, 0.0, noise=0.0)
    m = prepare_modal(rec, basis, ["tip"], warmup_s=1.5, judge_s=0.5)
    p = {"linear_stiffness.k": 1e4, "viscous.c": 5.0, "modal.drive": 1.0, "modal.g2.tip": 0.0}
    q = m.states(__import__("labjoint.models", fromlist=["Model"]).Model.parse("linear_stiffness+viscous"), p)
    j = m.judged
    w = 2 * np.pi * m.frequency_hz
    x, a = q[j, QUANTITY_ORDER["displacement"]], q[j, QUANTITY_ORDER["acceleration"]]
    assert np.max(np.abs(a + w * w * x)) < 1e-3 * np.max(np.abs(a))
    amp = 1.0 / abs(1e4 - w * w + 1j * 5.0 * w)
    assert np.max(np.abs(x)) == pytest.approx(amp, rel=1e-3)


def test_bad_input_named():
    basis, ms = _set(0.0)
    with pytest.raises(InputError, match="valanis cannot act on a mode"):
        fit_modal("linear_stiffness+valanis", ms[:1])
    with pytest.raises(InputError, match="outside the bounds") as e:
        fit_modal("linear_stiffness+viscous", ms[:1], start={"viscous.c": -1.0})
    assert e.value.field == "start.viscous.c"
    with pytest.raises(InputError, match="diverge"):
        fit_modal("linear_stiffness+viscous", ms[:1], start={"linear_stiffness.k": -1e6},
                  bounds={"linear_stiffness.k": (-2e6, -5e5)})
    for n in ("armature_mass_kg", "force_factor_n_per_a"):
        with pytest.raises(InputError, match="not identifiable") as e:
            shaker_identifiable([n])
        assert e.value.field == f"shaker.{n}"


def _stored(tmp_path, rec):
    """``rec`` as a run file of the data directory tmp_path/data (as `labjoint import` stores it)."""
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.csv_import import store_channels

    spec = lambda n, q, u: ChannelSpec(n, "imported", q, u, 1.0, range_v=np.inf, coupling="DC")  # noqa: E731
    return store_channels(tmp_path / "x.h5", rec.time, FS,
                          [(spec(c.name, c.quantity, c.units), c.samples) for c in rec.channels.values()],
                          {"frequency_hz": rec.metadata["frequency_hz"], "drive_channels": ["input_V"],
                           "response_channels": ["tip", "root"]}, tmp_path / "data", name="s1")


def test_cli_refuses_with_exit_2_and_saves_nothing(tmp_path, capsys):
    basis, modes = _basis()
    rec = _record(modes[0]["frequency_hz"] / 2, 1.0, 0.0)
    path = _stored(tmp_path, rec)
    mfile = tmp_path / "modes.json"
    mfile.write_text(json.dumps({"levels": [{"level": 1.0, "modes": modes}]}))
    out = tmp_path / "m.json"
    rc = main(["fit", str(path), "--modal", str(mfile), "--model", "linear_stiffness+valanis",
               "--out", str(out), "--json"])
    err = capsys.readouterr()
    assert rc == 2 and "valanis" in err.err and err.out == "" and not out.exists()


def test_cli_refuses_a_shaker_parameter_by_name(tmp_path, capsys):
    mfile = tmp_path / "modes.json"
    _, modes = _basis()
    mfile.write_text(json.dumps({"levels": [{"level": 1.0, "modes": modes}]}))
    rc = main(["fit", str(tmp_path / "none.h5"), "--modal", str(mfile), "--model",
               "linear_stiffness+viscous", "--shaker-fit", "armature_mass_kg", "--json"])
    err = capsys.readouterr()
    assert rc == 2 and "shaker.armature_mass_kg" in err.err and "not identifiable" in err.err
    assert err.out == ""


def test_modes_given_to_python_as_json_path_or_basis_alike(tmp_path):
    """compare's ``modal`` option takes the modes as REST does (the JSON already read), as a
    file path, or as a basis: the same measured modes; a dict that is not modes is refused
    naming modal, before any fit."""
    from labjoint.compare import fit_runs
    from labjoint.compare.modal_api import load_modal

    basis, modes = _basis()
    d = {"reference": "tip", "modes": modes}
    (tmp_path / "modes.json").write_text(json.dumps(d))
    run = _stored(tmp_path, _record(0.9 * modes[0]["frequency_hz"], 0.4, 0.0))
    got = [load_modal([run], None, {"modal": m, "responses": ["tip"]})[0][0].basis
           for m in (d, str(tmp_path / "modes.json"), basis)]
    same = [{k: v for k, v in b.to_dict().items() if k != "source"} for b in (*got, basis)]
    assert same[0] == same[1] == same[2] == same[3]
    with pytest.raises(InputError) as e:
        fit_runs([run], "linear_stiffness+viscous", modal={"levels": "none"}, responses=["tip"])
    assert "modal" in str(e.value.field)
