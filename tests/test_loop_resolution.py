"""Loop energy loss: calibrated sensor phase corrected, uncertainty propagated, and
W below its resolution flagged instead of reported (issue 12, item 4)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from labjoint.documents import Block, RunStart, RunStop
from labjoint.identify.analyze import analyze_file
from labjoint.storage.writer import RunWriter
from test_storage_fixtures import FS, quantise, rig_channels

F0, K = 400.0, 1.2e7
OMEGA = 2 * np.pi * F0


def _run(tmp_path, name, *, U, c, lag_deg, cal_phase=None, noise_n=0.0, seconds=0.5,
         seed=0):
    """A Kelvin-Voigt joint (K, c) whose nanocomposite force sensor lags by ``lag_deg``;
    ``cal_phase`` = (phase_deg, uncertainty_deg) the calibration found (or None)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FS)) / FS
    u = U * np.sin(OMEGA * t)
    lag = np.radians(lag_deg)
    f_sensed = K * U * np.sin(OMEGA * t - lag) + c * U * OMEGA * np.cos(OMEGA * t - lag)
    chans = rig_channels()
    nc = chans[3]
    if cal_phase is not None:
        nc = replace(nc, calibration_phase=((F0, cal_phase[0], cal_phase[1]),))
    chans[3] = nc
    volts = np.stack([
        (K * u + c * U * OMEGA * np.cos(OMEGA * t)) / 50.0,
        0.5 * u / 1.25e-5, -0.5 * u / 1.25e-5,
        (f_sensed + noise_n * rng.standard_normal(t.size)) / 301.0])
    uid = f"uid-{name}"
    w = RunWriter(tmp_path)
    w("start", RunStart(uid, name, chans, FS, {"frequency_hz": F0}))
    q = quantise(volts)
    for a in range(0, q.shape[1], 5000):
        w("block", Block(uid, a, q[:, a:a + 5000]))
    w("stop", RunStop(uid, "complete", n_samples=q.shape[1]))
    return tmp_path / f"{name}.h5"


def test_calibrated_sensor_phase_is_corrected(tmp_path):
    # c = 20 Ns/m at U = 1 um: W = pi c omega U^2 = 1.58e-7 J, phi = c omega / K = 4.2 mrad.
    # A 0.5 deg (8.7 mrad) sensor lag makes the raw loop negative; the calibration knows it.
    U, c = 1e-6, 20.0
    w_true = np.pi * c * OMEGA * U ** 2
    raw = analyze_file(_run(tmp_path, "raw", U=U, c=c, lag_deg=0.5)).summary
    assert raw["energy_loss_j"] < 0                       # what the old pipeline reported
    assert raw["below_resolution"] is True                # and now: not a result
    fixed = analyze_file(_run(tmp_path, "cal", U=U, c=c, lag_deg=0.5,
                              cal_phase=(0.5, 0.005))).summary
    assert fixed["energy_loss_j"] == pytest.approx(w_true, rel=0.02)
    assert fixed["damping_ns_per_m"] == pytest.approx(c, rel=0.02)
    assert fixed["below_resolution"] is False


def test_phase_uncertainty_propagates_into_w_and_c(tmp_path):
    # u_W from the phase is pi |F1| |U1| cos(phi) u_phi ~ pi K U^2 u_phi (systematic).
    U, c, u_deg = 5e-6, 400.0, 0.05
    s = analyze_file(_run(tmp_path, "u", U=U, c=c, lag_deg=0.2, cal_phase=(0.2, u_deg))).summary
    expected = np.pi * K * U ** 2 * np.radians(u_deg)
    assert s["energy_loss_j_uncertainty_phase"] == pytest.approx(expected, rel=0.01)
    assert s["energy_loss_j_uncertainty"] >= s["energy_loss_j_uncertainty_phase"]
    assert s["energy_loss_j_resolution"] == pytest.approx(2 * s["energy_loss_j_uncertainty"])
    assert s["damping_ns_per_m_uncertainty"] == pytest.approx(
        s["energy_loss_j_uncertainty"] / (np.pi * OMEGA * s["displacement_amplitude_m"] ** 2),
        rel=1e-9)
    assert s["energy_loss_j"] == pytest.approx(np.pi * c * OMEGA * U ** 2, rel=0.01)


def test_loop_within_the_phase_uncertainty_is_below_resolution(tmp_path):
    # True W = pi c omega U^2 with c = 5 Ns/m (phi = 1 mrad); the calibration phase is
    # only known to +-0.2 deg (3.5 mrad): W cannot be told from zero.
    res = analyze_file(_run(tmp_path, "small", U=2e-6, c=5.0, lag_deg=0.3,
                            cal_phase=(0.3, 0.2)))
    assert res.summary["below_resolution"] is True
    assert res.below_resolution[res.steady].all()
    assert res.energy_loss_uncertainty.shape == res.energy_loss.shape


def test_noise_alone_sets_the_resolution_without_a_phase_calibration(tmp_path):
    # Uncalibrated sensor, no lag, large force noise: the scatter of W decides.
    U, c = 3e-6, 300.0
    res = analyze_file(_run(tmp_path, "noisy", U=U, c=c, lag_deg=0.0, noise_n=3.0))
    s = res.summary
    sd = float(np.std(res.energy_loss[res.steady], ddof=1))
    assert s["energy_loss_j_uncertainty"] == pytest.approx(sd / np.sqrt(s["cycles"]), rel=1e-6)
    assert "not calibrated" in res.metadata["phase_note"]
    assert s["below_resolution"] is False
