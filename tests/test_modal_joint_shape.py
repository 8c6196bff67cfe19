"""A joint no sensor pair sees (issue 29 item 5): the modal model with the joint's
participation in modes 2..N fitted (``modal.joint<j>``, ``--fit-joint-shape``) against the
independent physical chain of tests/test_nlmode_pair.py (solve_ivp in physical coordinates,
a quadratic + cubic spring between masses 2 and 3), fitted as if the joint sat between
sensors s1 and s3: the named pair's shapes misplace the joint, the fitted participations put
it back."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.structure.nlmode import Drive
from labjoint.structure.nlmode_pair import joint_participation, pair_response, pair_states
from tests.test_nlmode_pair import FS, _basis_and_params, _record, _reference, volts


def _true_participation(basis, pair=("s1", "s3")):
    """The chain's joint (masses 2-3) expressed in the named pair's units: D_j of the
    fitted model = (D_1 of the pair / D_1 of the joint) x D_j of the joint."""
    d_true = np.array([m.shape["s2"] - m.shape["s3"] for m in basis.modes])
    d_pair = np.array([m.shape[pair[0]] - m.shape[pair[1]] for m in basis.modes])
    return d_pair, d_true * d_pair[0] / d_true[0], d_pair[0] / d_true[0]


def test_fitted_participation_reproduces_the_chain_from_the_wrong_pair():
    """The model with the named pair's D_1 and the joint's D_j (j >= 2) rescaled to it is
    the chain exactly: a polynomial law rescales (k2 / c^3, k3 / c^4 for u' = c u), the
    masses stay; with the pair's own D_j it is not."""
    t, x, _ = _reference()
    basis, p = _basis_and_params()
    d_pair, d_fit, c = _true_participation(basis)
    q = {**p, "quadratic_stiffness.k2": p["quadratic_stiffness.k2"] / c ** 3,
         "cubic_stiffness.k3": p["cubic_stiffness.k3"] / c ** 4}
    q.update({f"modal.joint{j}": float(d_fit[j - 1]) for j in (2, 3)})
    assert joint_participation(basis, ("s1", "s3"), q) == pytest.approx(d_fit)
    assert joint_participation(basis, ("s1", "s3")) == pytest.approx(d_pair)
    drive = Drive.of(volts(t), FS, highest_hz=basis.modes[-1].frequency_hz)
    nrmse = lambda m, r: np.sqrt(np.mean((m - r) ** 2) / np.mean(r ** 2))  # noqa: E731
    st = pair_states("quadratic_stiffness+cubic_stiffness", q, basis, ("s1", "s3"), drive)
    for i, s in enumerate(("s1", "s2", "s3")):
        assert nrmse(pair_response(st, basis, s, "displacement"), x[:, i]) < 2e-4
    q2 = {k: v for k, v in q.items() if not k.startswith("modal.joint")}
    wrong = pair_states("quadratic_stiffness+cubic_stiffness", q2, basis, ("s1", "s3"), drive)
    assert nrmse(pair_response(wrong, basis, "s3", "displacement"), x[:, 2]) > 0.02
    with pytest.raises(InputError) as e:
        joint_participation(basis, ("s1", "s3"), {"modal.joint2": float("nan")})
    assert e.value.field == "modal.joint2"


@pytest.mark.slow
def test_fit_joint_shape_recovers_the_participation_the_pair_misses():
    """Records of the chain at two levels fitted through the modal kind with the joint named
    between s1 and s3: with the pair's shapes the fit is left far from the records; with
    the participations fitted it reaches the noise, the ratios D_j / D_1 of the true joint
    come back within 2 %, and it predicts the level it never saw."""
    from dataclasses import replace

    from labjoint.compare.kinds.modal import ModalSetup
    from labjoint.compare.kinds.modal_prepare import prepare_modal
    from labjoint.compare.kinds.modal_maps import MODAL
    basis, _ = _basis_and_params()
    _, d_fit, _ = _true_participation(basis)
    recs = [_record(0.5, "low"), _record(1.0, "high")]
    ms = [prepare_modal(r, basis, between=("s1", "s3")) for r in recs]
    model = "quadratic_stiffness+cubic_stiffness"
    fixed = MODAL.fit(model, ms[1:], ms[:1])
    shaped = [replace(m, setup=ModalSetup(joint_shape=True)) for m in ms]
    fit = MODAL.fit(model, shaped[1:], shaped[:1])
    v = fit.params_.valuesdict()
    assert fit.nrmse_ < 2e-3 and fit.validation_nrmse_ < 2e-3, (fit.nrmse_, fit.validation_nrmse_)
    assert fixed.nrmse_ > 10 * fit.nrmse_, (fixed.nrmse_, fit.nrmse_)
    for j in (2, 3):
        assert v[f"modal.joint{j}"] == pytest.approx(d_fit[j - 1], rel=0.02), j


def test_joint_shape_goes_with_between(tmp_path, capsys):
    from labjoint.cli.main import main
    from labjoint.compare.modal_api import load_modal
    with pytest.raises(InputError) as e:
        load_modal([str(tmp_path / "x.h5")], None, {"modal": {"levels": []}, "joint_shape": True})
    assert e.value.field == "joint_shape"
    for extra in ([], ["--modal", str(tmp_path / "modes.json")]):
        assert main(["fit", str(tmp_path / "x.h5"), "--model", "cubic_stiffness",
                     "--fit-joint-shape", *extra, "--json"]) == 2
        err = capsys.readouterr().err
        assert "--fit-joint-shape goes with --modal and --between" in err, err
