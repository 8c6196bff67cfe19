"""The modal kind's measured and model responses per record (the page's overlays and
`--full` JSON), against the independent generator of tests/spectra_runs.py (the coil-driven
2-DOF chain, velocities by scipy's lsim): each trace is the stored response itself over the
judged span (its mean removed) in its own SI unit, and the linear modal model, fitted,
follows it."""

from __future__ import annotations

import numpy as np

from labjoint.compare.api import fit_runs
from labjoint.storage import open_run
from spectra_runs import measured_modes, random_voltage


def test_modal_traces_are_the_stored_responses_and_the_model_follows(tmp_path):
    rec = random_voltage(tmp_path / "a.h5", 0.3, seed=3, n=1 << 13)
    d = fit_runs([str(rec)], "linear_stiffness+viscous", modal=measured_modes(rec), full=True)
    tr = d["loops"]["a"]
    assert set(tr["responses"]) == {"vel1", "vel2"}
    t = np.asarray(tr["time_s"])
    with open_run(rec) as rf:
        fs = rf.sample_rate_hz
        idx = np.rint(t * fs).astype(int)
        assert 2 <= t.size <= 2048 and np.all(np.diff(idx) > 0)
        for ch, r in tr["responses"].items():
            assert (r["quantity"], r["unit"]) == ("velocity", "m/s")
            raw = rf.physical(ch)[idx[0]:idx[-1] + 1]
            stored = rf.physical(ch)[idx] - raw.mean()
            meas, model = np.asarray(r["measured"]), np.asarray(r["model"])
            scale = np.std(stored)
            # the judged span's mean (every sample) vs the decimated ones: equal within a
            # fraction of the response's rms
            assert np.max(np.abs(meas - stored)) < 0.05 * scale, ch
            assert np.std(meas - (stored - stored.mean())) < 1e-6 * scale, ch
            assert np.sqrt(np.mean((model - meas) ** 2)) < 0.05 * np.std(meas), ch
    assert d["nrmse"] < 0.03
