"""Issue 33 item 3: a friction test whose loop slides on plateaus was given a stick-slip
macro-slip fraction of 0 % and W = 4.3 mJ against 11.7 mJ measured.

Cause: K_t was the loop's overall least-squares slope, which averages the sliding
plateaus (slope 0) in with the stick branches, so K_t U never reached mu N; and U was
measured from the record's global mean (a sliding joint drifts) with five harmonics (a
sliding joint's displacement has more). The independent generator here is a Jenkins
element (spring k in series with a Coulomb slider at f_s) written in the test: in
gross slip (U > f_s / k) every cycle slides as a whole and W = 4 f_s (U - f_s / k).
With K_t = k / 2 and f_max = f_s the model's W (seed 002 Eq. 7 integrated) is
2 K_t u*^2 + 4 f_s (U - u*), u* = f_s / K_t, which is exactly that closed form.
"""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.identify.quarters import band_limited_peaks, period_mean
from labjoint.identify.stickslip import StickSlipIdentifier

FS, F_HZ = 50_000.0, 100.0
K, F_S, N = 8e6, 100.0, 500.0            # stick stiffness, slip force, normal force
MU = F_S / N


def jenkins_record(amplitude_m: float, drift_m_per_s: float = 0.0, seconds: float = 0.3,
                   noise_n: float = 0.05, seed: int = 3):
    """u = U sin(w t) (+ a slow drift) and the Jenkins force along it, with force noise."""
    t = np.arange(int(seconds * FS)) / FS
    u = amplitude_m * np.sin(2 * np.pi * F_HZ * t) + drift_m_per_s * t
    f = np.empty_like(u)
    slider = 0.0
    for i, x in enumerate(u):
        trial = K * (x - slider)
        if trial > F_S:
            slider = x - F_S / K
        elif trial < -F_S:
            slider = x + F_S / K
        f[i] = K * (x - slider)
    f += np.random.default_rng(seed).normal(0.0, noise_n, f.size)
    return u, f


def identify(u, f):
    est = StickSlipIdentifier(MU, cutoff_hz=None)
    est.fit_arrays(u, f, FS, F_HZ, name="jenkins", metadata={"normal_force_n": N})
    return est.result_


@pytest.mark.parametrize("ratio", [3.0, 6.0])
def test_a_jenkins_loop_in_gross_slip_is_all_macro_slip_with_its_closed_form_energy(ratio):
    U = ratio * F_S / K
    r = identify(*jenkins_record(U))
    s = r.summary
    w_exact = 4 * F_S * (U - F_S / K)
    assert s["macro_slip_fraction"] == 1.0
    assert s["energy_loss_j"] == pytest.approx(w_exact, rel=0.01)
    assert r.shear_stiffness.value == pytest.approx(K / 2, rel=0.01)
    assert "stick-branch" in r.shear_stiffness.method
    assert s["displacement_amplitude_m"] == pytest.approx(U, rel=2e-3)


def test_a_drifting_sliding_joint_keeps_its_amplitude_and_energy():
    U = 4 * F_S / K
    r = identify(*jenkins_record(U, drift_m_per_s=2e-4))     # 0.2 um per cycle
    assert r.summary["displacement_amplitude_m"] == pytest.approx(U, rel=3e-3)
    assert r.summary["energy_loss_j"] == pytest.approx(4 * F_S * (U - F_S / K), rel=0.015)
    assert r.summary["macro_slip_fraction"] == 1.0


def test_a_loop_without_plateaus_keeps_the_least_squares_slope_and_no_macro_slip():
    # an elliptic (linear + viscous) loop: the seed's micro-slip case, unchanged
    t = np.arange(int(0.3 * FS)) / FS
    U, k, c = 10e-6, 8e6, 2000.0
    w = 2 * np.pi * F_HZ
    u = U * np.sin(w * t)
    f = k * u + c * U * w * np.cos(w * t)
    r = identify(u, f)
    assert r.summary["macro_slip_fraction"] == 0.0
    assert r.shear_stiffness.value == pytest.approx(k / 2, rel=1e-3)
    assert r.summary["energy_loss_j"] == pytest.approx(k * U * U, rel=2e-3)   # 2 K_t U^2


def test_period_mean_and_half_range_peaks_of_a_skewed_drifting_cycle():
    t = np.arange(5000) / FS
    w = 2 * np.pi * F_HZ
    # a sliding joint's odd harmonics up to the 9th, on a drift: half peak-to-peak known
    u = np.sin(w * t) + 0.12 * np.sin(3 * w * t) + 0.05 * np.sin(5 * w * t) \
        + 0.025 * np.sin(7 * w * t) + 0.01 * np.sin(9 * w * t)
    grid = np.linspace(0, 1 / F_HZ, 20001)
    g = np.sin(w * grid) + 0.12 * np.sin(3 * w * grid) + 0.05 * np.sin(5 * w * grid) \
        + 0.025 * np.sin(7 * w * grid) + 0.01 * np.sin(9 * w * grid)
    half = (g.max() - g.min()) / 2
    drifting = u + 30.0 * t
    centred = drifting - period_mean(drifting, FS, F_HZ)
    peaks = np.flatnonzero((centred[1:-1] > centred[:-2]) & (centred[1:-1] >= centred[2:])) + 1
    peaks = peaks[(peaks > 600) & (peaks < 4400)]
    got = band_limited_peaks(centred, peaks, FS, F_HZ, half_range=True)
    assert np.allclose(got, half, rtol=1e-4)


def test_the_simulated_friction_test_is_macro_slip_with_the_measured_energy(tmp_path):
    from test_stickslip_simrig import write_sim_run
    from labjoint.identify.methods import analyze_runs

    path = write_sim_run(tmp_path, "friction_test_100Hz_2Nm", 100.0, 20.0, 2.0)
    from labjoint.identify.friction import identify_friction
    from labjoint.storage import read_run
    mu = identify_friction(read_run(path))
    row = analyze_runs([path], "both", friction=mu)[0]
    assert row["stickslip_macro_slip_fraction"] == 1.0
    assert row["stickslip_energy_loss_j"] == pytest.approx(row["energy_loss_j"], rel=0.03)
    assert row["stickslip_displacement_amplitude_m"] == pytest.approx(
        row["displacement_amplitude_m"], rel=0.005)
    assert "stick-branch" in row["shear_stiffness_method"]
