"""Complex measured modes in the modal model (nlmode eq. 3b), against the independent
generator of tests/spectra_runs.py: the 2-DOF chain driven through a strongly coupled coil
(Bl 10 N/A, R 2 ohm: the back-EMF damps mass 1 only, so its modes are complex, mode 2's
vel1 15.6 deg from real), velocities integrated by scipy's lsim, its modes measured as a
user would (`labjoint modes`). The chain is linear: the linear modal model must reach the
noise with the quadrature participations, and cannot without them (the same modes with
their imaginary parts dropped); the fitted model, saved, predicts a record it never saw."""

from __future__ import annotations

import json

import numpy as np
import pytest

from labjoint.compare.api import fit_report
from labjoint.compare.modal_api import predict_modal, save_modal
from spectra_runs import measured_modes, random_voltage


def _real(modes):
    d = json.loads(json.dumps(modes))
    for lv in d["levels"]:
        for m in lv["modes"]:
            m["shape"] = {k: [float(np.sign(v[0]) * np.hypot(*v)), 0.0] for k, v in m["shape"].items()}
    return d


def test_a_linear_structure_with_complex_modes_is_reproduced(tmp_path):
    fit_rec = random_voltage(tmp_path / "a.h5", 0.3, seed=3, n=1 << 13)
    new_rec = random_voltage(tmp_path / "b.h5", 0.3, seed=4, n=1 << 13)
    modes = measured_modes(fit_rec)
    rep = fit_report([str(fit_rec)], "linear_stiffness+viscous", modal=modes)
    d = rep.to_dict()
    assert rep.fit.nrmse_ < 0.03, rep.fit.nrmse_
    h = {k for k in d["parameters"] if k.startswith("modal.h")}
    assert h == {"modal.h1.vel1", "modal.h2.vel1", "modal.h2.vel2"}
    real = fit_report([str(fit_rec)], "linear_stiffness+viscous", modal=_real(modes))
    assert real.fit.nrmse_ > 3 * rep.fit.nrmse_, (real.fit.nrmse_, rep.fit.nrmse_)
    assert not any(k.startswith("modal.h") for k in real.to_dict()["parameters"])
    save_modal(rep.fit, rep.evaluation.runs_measured(), tmp_path / "m.json")
    pred = predict_modal(tmp_path / "m.json", new_rec)
    assert pred["nrmse"] < 0.03, pred["nrmse"]


def test_a_diagnosis_of_one_record_is_refused_naming_runs(tmp_path):
    """One modal record is fitted, never validated: a diagnosis, which judges candidates on
    records it did not fit, refuses it by name before any fit (it was a numpy error)."""
    from labjoint.compare import diagnose_runs
    from labjoint.errors import InputError

    rec = random_voltage(tmp_path / "a.h5", 0.3, seed=3, n=1 << 12)
    with pytest.raises(InputError) as e:
        diagnose_runs([str(rec)], "linear_stiffness+viscous", modal=measured_modes(rec))
    assert e.value.field == "runs" and "two or more records" in e.value.message


def test_the_joint_between_two_points_reads_complex_modes(tmp_path):
    """The two-point form (nlmode_pair eq. 7b): nothing per sensor is fitted, so the sensors
    must read the measured imaginary parts; the linear chain then reaches the noise and a
    saved model (its basis with the [re, im] shapes) predicts a record it never saw. With
    the imaginary parts dropped it cannot."""
    fit_rec = random_voltage(tmp_path / "a.h5", 0.3, seed=3, n=1 << 13)
    new_rec = random_voltage(tmp_path / "b.h5", 0.3, seed=4, n=1 << 13)
    modes = measured_modes(fit_rec)
    rep = fit_report([str(fit_rec)], "linear_stiffness+viscous", modal=modes, between=("vel1", "vel2"))
    real = fit_report([str(fit_rec)], "linear_stiffness+viscous", modal=_real(modes),
                      between=("vel1", "vel2"))
    assert rep.fit.nrmse_ < 0.04, rep.fit.nrmse_
    assert real.fit.nrmse_ > 3 * rep.fit.nrmse_, (real.fit.nrmse_, rep.fit.nrmse_)
    save_modal(rep.fit, rep.evaluation.runs_measured(), tmp_path / "m.json")
    saved = json.loads((tmp_path / "m.json").read_text())
    assert any(isinstance(v, list) and v[1] != 0
               for m in saved["basis"]["modes"] for v in m["shape"].values())
    assert predict_modal(tmp_path / "m.json", new_rec)["nrmse"] < 0.04


@pytest.mark.parametrize("d", [0, 1, 2])
def test_a_complex_shape_reads_its_phasor_at_the_mode(d):
    """Eq. 7b against the closed form: at the mode's own frequency, eta = cos(w t), a sensor
    of shape a + i b reads Re((a + i b) (i w)^d e^{i w t}) (to sin(w h)/(w h) for d = 2)."""
    from labjoint.structure.modal_basis import MeasuredMode
    from labjoint.structure.nlmode_pair import mode_reading

    f, fs, a, b = 12.0, 2000.0, 0.7, -0.3
    w, t = 2 * np.pi * f, np.arange(4000) / 2000.0
    x = np.column_stack([np.cos(w * t), -w * np.sin(w * t), -w * w * np.cos(w * t)])
    mode = MeasuredMode(f, 0.01, {"s": a}, shape_im={"s": b})
    got = mode_reading(x, mode, "s", d, fs)[1:-1]
    want = np.real((a + 1j * b) * (1j * w) ** d * np.exp(1j * w * t))[1:-1]
    assert np.max(np.abs(got - want)) < 2e-3 * np.max(np.abs(want))
    assert np.max(np.abs(mode_reading(x, MeasuredMode(f, 0.01, {"s": a}), "s", d)
                         - a * x[:, d])) == 0.0
