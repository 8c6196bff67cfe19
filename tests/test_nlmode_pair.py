"""The modal model's joint between two measured points (issue 29 item 5) against an
independent generator: a 3-mass chain with a quadratic + cubic spring between masses 2 and
3, integrated here in physical coordinates by scipy's solve_ivp (no modal reduction, no
labjoint law); the modal model gets only what `labjoint modes` would measure: frequencies,
damping ratios and shapes relative to the reference sensor."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import eigh

from labjoint.errors import InputError
from labjoint.structure.nlmode import Drive, MeasuredMode, ModalBasis
from labjoint.structure.nlmode_pair import pair_response, pair_states, relative_displacement

M = np.diag([1.0, 0.6, 0.4])
K = np.array([[3e4, -1e4, 0.0], [-1e4, 1.8e4, -8e3], [0.0, -8e3, 8e3]])
ZETA = np.array([0.02, 0.015, 0.01])
K2, K3 = 4e5, 2e9                  # the joint between masses 2 and 3: F = k2 u^2 + k3 u^3
GAIN = 20.0                        # N per volt at mass 1
FS, T = 400.0, 6.0
TONES = ((4.0, 0.6, 0.3), (11.0, 0.5, 1.1), (19.0, 0.3, 2.0))   # f (Hz), amplitude (V), phase


def volts(t):
    return sum(a * np.sin(2 * np.pi * f * t + p) - a * np.sin(p) * np.exp(-t) for f, a, p in TONES)


def _reference(joint: bool = True) -> np.ndarray:
    w2, phi = eigh(K, M)
    C = M @ phi @ np.diag(2 * ZETA * np.sqrt(w2)) @ phi.T @ M
    Mi = np.linalg.inv(M)

    def rhs(t, s):
        x, v = s[:3], s[3:]
        f = np.array([GAIN * volts(t), 0.0, 0.0])
        if joint:
            u = x[1] - x[2]
            F = K2 * u * u + K3 * u ** 3
            f += np.array([0.0, -F, F])
        return np.r_[v, Mi @ (f - C @ v - K @ x)]

    t = np.arange(int(T * FS)) / FS
    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(6), t_eval=t, method="DOP853", rtol=1e-11, atol=1e-14)
    acc = np.array([rhs(ti, si)[3:] for ti, si in zip(t, sol.y.T)])
    return t, sol.y[:3].T, acc


def _basis_and_params():
    w2, phi = eigh(K, M)                                  # mass-normalised
    ref = phi[0]                                          # sensor s1, the drive point
    modes = tuple(MeasuredMode(float(np.sqrt(w2[j]) / (2 * np.pi)), float(ZETA[j]),
                               {f"s{i + 1}": float(phi[i, j] / ref[j]) for i in range(3)}) for j in range(3))
    basis = ModalBasis(modes, "s1")
    p = {"quadratic_stiffness.k2": K2 * ref[0] ** 2, "cubic_stiffness.k3": K3 * ref[0] ** 2}
    for j in range(3):
        p[f"modal.drive{j + 1}"] = GAIN * ref[j] ** 2
        if j:
            p[f"modal.mass{j + 1}"] = ref[0] ** 2 / ref[j] ** 2
    return basis, p


def test_two_point_joint_matches_the_physical_chain():
    t, x, a = _reference()
    basis, p = _basis_and_params()
    drive = Drive.of(volts(t), FS, highest_hz=basis.modes[-1].frequency_hz)
    st = pair_states("quadratic_stiffness+cubic_stiffness", p, basis, ("s2", "s3"), drive)
    nrmse = lambda m, r: np.sqrt(np.mean((m - r) ** 2) / np.mean(r ** 2))  # noqa: E731
    for i, s in enumerate(("s1", "s2", "s3")):
        assert nrmse(pair_response(st, basis, s, "displacement"), x[:, i]) < 2e-4
        assert nrmse(pair_response(st, basis, s, "acceleration"), a[:, i]) < 2e-4
    u = relative_displacement(st, basis, ("s2", "s3"))
    assert nrmse(u, x[:, 1] - x[:, 2]) < 2e-4
    # the joint matters here: without it the chain's response is far off
    _, x_lin, _ = _reference(joint=False)
    assert nrmse(x_lin[:, 2], x[:, 2]) > 0.05
    # the joint on the wrong pair is not the chain
    wrong = pair_states("quadratic_stiffness+cubic_stiffness", p, basis, ("s1", "s2"), drive)
    assert nrmse(pair_response(wrong, basis, "s3", "displacement"), x[:, 2]) > 0.02


def test_two_point_joint_refusals():
    basis, p = _basis_and_params()
    drive = Drive.of(np.zeros(64), FS)
    with pytest.raises(InputError, match="no sensor 's9'"):
        pair_states("cubic_stiffness", p, basis, ("s2", "s9"), drive)
    with pytest.raises(InputError, match="two different sensors"):
        pair_states("cubic_stiffness", p, basis, ("s2", "s2"), drive)
    with pytest.raises(InputError, match="wear"):
        pair_states("wear", p, basis, ("s2", "s3"), drive)
    q = dict(p)
    q.pop("modal.drive2")
    with pytest.raises(InputError) as e:
        pair_states("cubic_stiffness", q, basis, ("s2", "s3"), drive)
    assert e.value.field == "modal.drive2"


def _record(scale: float, name: str):
    from labjoint.storage.channels import Channel, ChannelRecord
    global GAIN
    g0 = GAIN
    GAIN = g0 * scale
    try:
        t, x, a = _reference()
    finally:
        GAIN = g0
    rng = np.random.default_rng(int(scale * 100))
    chans = {"v": Channel("v", scale * volts(t), "voltage", "V", "drive")}
    for i, (nm, qty, y, unit) in enumerate((("s1", "acceleration", a[:, 0], "m/s^2"),
                                            ("s2", "displacement", x[:, 1], "m"),
                                            ("s3", "acceleration", a[:, 2], "m/s^2"))):
        chans[nm] = Channel(nm, y + 1e-4 * y.std() * rng.standard_normal(y.size), qty, unit, "response")
    return ChannelRecord(name, t, FS, chans, {})


@pytest.mark.slow
def test_fit_between_two_points_recovers_the_joint():
    """Records of the physical chain at two levels (voltage drive, acceleration and
    displacement responses, 0.01 % noise) fitted through the modal kind with the joint
    between s2 and s3: the law (converted to mode 1's unit modal mass) and the drives come
    back (and the relative modal masses), validated on the level not fitted."""
    from labjoint.compare.kinds.modal_prepare import prepare_modal
    from labjoint.compare.kinds.modal_maps import MODAL
    basis, truth = _basis_and_params()
    recs = [_record(0.5, "low"), _record(1.0, "high")]
    ms = [prepare_modal(r, basis, between=("s2", "s3")) for r in recs]
    fit = MODAL.fit("quadratic_stiffness+cubic_stiffness", ms[1:], ms[:1])
    v = fit.params_.valuesdict()
    assert fit.nrmse_ < 1e-3 and fit.validation_nrmse_ < 1e-3
    for k in truth:
        assert v[k] == pytest.approx(truth[k], rel=2e-3), k
        se = fit.params_[k].stderr          # finite, and covering the small error it made
        assert 0 < se < 2e-3 * abs(truth[k]) and abs(v[k] - truth[k]) < 10 * se, k
    assert v["shaker.highpass_hz"] < 0.05
    with pytest.raises(InputError, match="no sensor 'tip'"):
        prepare_modal(recs[0], basis, between=("tip", "s3"))


@pytest.mark.slow
def test_cli_fit_between_saves_and_predicts(tmp_path, capsys):
    """`fit --modal MODES.json --between s2,s3 --out` then `predict` on the other level."""
    import json

    from labjoint.cli.main import main
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.csv_import import store_channels

    basis, truth = _basis_and_params()
    paths = []
    for scale, name in ((1.0, "high"), (0.5, "low")):
        rec = _record(scale, name)
        spec = lambda n, q, u: ChannelSpec(n, "imported", q, u, 1.0, range_v=np.inf, coupling="DC")  # noqa: E731
        paths.append(store_channels(tmp_path / f"{name}.h5", rec.time, FS,
                                    [(spec(c.name, c.quantity, c.units), c.samples) for c in rec.channels.values()],
                                    {"drive_channels": ["v"], "response_channels": ["s1", "s2", "s3"]},
                                    tmp_path / "data", name=name))
    modes = [{"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio, "shape": m.shape,
              "reference_sensor": "s1"} for m in basis.modes]
    mfile = tmp_path / "modes.json"
    mfile.write_text(json.dumps({"levels": [{"level": 1.0, "modes": modes}]}))
    out = tmp_path / "pair.json"
    rc = main(["fit", str(paths[0]), "--modal", str(mfile), "--between", "s2,s3", "--model",
               "quadratic_stiffness+cubic_stiffness", "--out", str(out), "--json"])
    res = json.loads(capsys.readouterr().out)
    assert rc == 0 and res["nrmse"] < 1e-3
    assert res["parameters"]["cubic_stiffness.k3"]["value"] == pytest.approx(truth["cubic_stiffness.k3"], rel=2e-3)
    assert json.loads(out.read_text())["between"] == ["s2", "s3"]
    rc = main(["predict", str(out), str(paths[1]), "--json"])
    pred = json.loads(capsys.readouterr().out)
    assert rc == 0 and pred["nrmse"] < 1e-3
    rc = main(["fit", str(paths[0]), "--modal", str(mfile), "--between", "s2,s9", "--model",
               "cubic_stiffness", "--json"])
    err = capsys.readouterr()
    assert rc == 2 and "s9" in err.err and err.out == ""
    rc = main(["fit", str(paths[0]), "--between", "s2,s3", "--model", "cubic_stiffness", "--json"])
    err = capsys.readouterr()
    assert rc == 2 and "--modal" in err.err and err.out == ""
