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
