"""Stick-slip energy loss independent of the sample rate (issue 33 item 7, seed 002
Eqs. 2-9): U is the band-limited cycle maximum, not the largest sample.

The records are a pure sine written here (not the simulator), sampled so that the peak
falls half-way between two samples, where the largest sample is U cos(pi / spc)."""

import numpy as np
import pytest

from labjoint.identify.stickslip import StickSlipIdentifier

F, U, KT, MU = 400.0, 6e-6, 5.9e6, 0.168


def _summary(spc: int, phase_samples: float = 0.5) -> dict:
    fs = F * spc
    t = (np.arange(int(0.25 * fs)) + phase_samples) / fs
    u = U * np.sin(2 * np.pi * F * t - np.pi / 2)          # a peak half-way between samples
    est = StickSlipIdentifier(MU, shear_stiffness=KT).fit_arrays(
        u, None, fs, F, name=f"spc{spc}", metadata={"torque_nm": 5.0})
    return est.result_.summary


def test_the_largest_sample_would_miss_the_peak():
    spc = 20
    t = (np.arange(200) + 0.5) / (F * spc)
    u = U * np.sin(2 * np.pi * F * t - np.pi / 2)
    assert u.max() / U == pytest.approx(np.cos(np.pi / spc), rel=1e-9)    # 1.2 % low


@pytest.mark.parametrize("spc", [20, 50, 500])
def test_energy_loss_is_the_closed_form_at_any_rate(spc):
    s = _summary(spc)
    assert s["displacement_amplitude_m"] == pytest.approx(U, rel=5e-4)
    assert s["energy_loss_j"] == pytest.approx(2 * KT * U ** 2, rel=1e-3)   # Eq. 7, micro-slip
    assert s["damping_ns_per_m"] == pytest.approx(2 * KT / (np.pi * 2 * np.pi * F), rel=1e-3)


def test_rates_agree_within_a_tenth_of_a_percent():
    w = {(spc, ph): _summary(spc, ph)["energy_loss_j"] for spc in (20, 50, 500)
         for ph in (0.5, 0.25)}
    assert max(w.values()) / min(w.values()) - 1 < 1e-3
