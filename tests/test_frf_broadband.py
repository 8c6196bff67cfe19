"""Broadband FRFs and modes against closed forms: a 2-DOF system integrated by scipy lsim
(the builder in tests/spectra_runs.py, shared with the /spectra tests), measured in
acceleration and velocity, driven by a force and by a voltage through a shaker (coil:
L di/dt + R i + Bl v = V, force Bl i); random and multisine drives."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from labjoint.errors import InputError
from labjoint.identify.modes import find_modes
from labjoint.signal.broadband import estimate
from labjoint.signal.frf_levels import frfset_from_arrays
from labjoint.signal.frfset import FrfSet
from spectra_runs import closed_frf, closed_modes, simulate


@pytest.mark.parametrize("shaker", [False, True])
def test_random_drive_modes_within_a_tenth_of_a_percent(shaker):
    fs, n = 256.0, 1 << 17
    rng = np.random.default_rng(3)
    u = rng.normal(size=n) * (0.2 if shaker else 10.0)
    y = simulate(u, fs, shaker)
    s = frfset_from_arrays(u, "voltage" if shaker else "force",
                           {"v2": ("velocity", y["v2"]), "a1": ("acceleration", y["a1"]),
                            "a2": ("acceleration", y["a2"])}, fs, run="r")
    assert s.units == ("m/s/V" if shaker else "m/s/N") and s.quantity == "velocity"
    assert s.metadata["converted"] == {"a1": "acceleration -> velocity", "a2": "acceleration -> velocity"}
    h = s.response[:, :, 0].T
    modes = find_modes(s.frequencies_hz, h, s.quantity, s.sensors, (5.0, 60.0))
    want = closed_modes(shaker)
    assert len(modes) == 2
    for m, (fn, z) in zip(modes, want):
        assert m["frequency_hz"] == pytest.approx(fn, rel=1e-3)
        assert m["damping_ratio"] == pytest.approx(z, rel=0.1)
    # mode 1 in phase at both masses, mode 2 out of phase (velocity a1/iw beside v2)
    sh = [np.array(modes[i]["shape"]["a1"]) @ np.array(modes[i]["shape"]["a2"]) for i in range(2)]
    assert sh[0] > 0 > sh[1]


def test_multisine_is_exact_at_the_excited_lines_and_its_std_follows_the_noise():
    fs, N, P = 256.0, 2560, 8
    rng = np.random.default_rng(5)
    k = np.arange(5, 300, 3)
    U = np.zeros(N // 2 + 1, complex)
    U[k] = np.exp(2j * np.pi * rng.random(k.size))
    u1 = np.fft.irfft(U, N) * N / k.size
    u = np.tile(u1, P + 2)
    y = simulate(u, fs, shaker=True)
    r = estimate(u, np.vstack([y["v2"], y["a1"]]), fs)
    assert "steady periods" in r.method and r.freq_hz.size == k.size
    want = closed_frf(r.freq_hz, True, 1, fs)
    assert np.max(np.abs(r.h[0] / want - 1)) < 1e-3
    noisy = y["v2"] + 1e-4 * rng.normal(size=u.size)
    r2 = estimate(u, noisy[None], fs)
    z = (r2.h[0] - want) / r2.std[0]
    assert 0.6 < np.std(np.concatenate([z.real, z.imag])) < 1.5


def test_a_burst_and_its_free_decay_form_one_unwindowed_block():
    """The default (burst="block"): one 32 s burst, then 32 s of rest: the block holds the
    burst's whole response, so H1 is the sampled system's FRF (no window, no leakage)
    wherever the drive has power."""
    fs = 256.0
    rng = np.random.default_rng(7)
    u = np.concatenate([rng.normal(size=1 << 13), np.zeros(1 << 13)])
    y = simulate(u, fs, shaker=False)
    r = estimate(u, y["v2"][None] + 1e-6 * rng.normal(size=u.size), fs)
    assert r.method.startswith("H1 over 1 burst block") and r.averages == 1
    assert "burst=block" in r.method
    assert r.active_s[1] == pytest.approx(32.0, abs=0.1)
    assert r.freq_hz[1] - r.freq_hz[0] == pytest.approx(1 / 64.0, rel=0.01)
    _assert_closed_form_velocity(r, fs)


def test_the_driven_option_takes_a_burst_over_its_driven_part_with_the_transients_removed():
    """burst="driven": the driven part alone, cut unwindowed while the modes ring, through
    the local rational method gives the sampled system's FRF (the transient at the cut
    removed) wherever the drive has power."""
    fs = 256.0
    rng = np.random.default_rng(7)
    u = np.concatenate([rng.normal(size=1 << 13), np.zeros(1 << 13)])
    y = simulate(u, fs, shaker=False)
    r = estimate(u, y["v2"][None] + 1e-6 * rng.normal(size=u.size), fs, burst="driven")
    assert r.method.startswith("H1 over the driven part of 1 burst(s)") and r.averages == 1
    assert "burst=driven" in r.method
    assert r.active_s[1] == pytest.approx(32.0, abs=0.1)
    assert r.freq_hz[1] - r.freq_hz[0] == pytest.approx(1 / 32.0, rel=0.01)
    _assert_closed_form_velocity(r, fs)


@pytest.mark.parametrize("mode,text", [("block", "6 burst block(s)"), ("driven", "6 burst(s)")])
def test_several_bursts_are_averaged_with_their_coherence(mode, text):
    fs = 256.0
    rng = np.random.default_rng(8)
    on, off = 1 << 12, 1 << 12
    u = np.concatenate([np.concatenate([rng.normal(size=on), np.zeros(off)]) for _ in range(6)])
    v = simulate(u, fs, shaker=False)["v2"]
    y = v + 0.05 * v.std() * rng.normal(size=u.size)
    r = estimate(u, y[None], fs, burst=mode)
    assert r.averages == 6 and text in r.method
    band = (r.freq_hz > 5) & (r.freq_hz < 60)
    assert 0.5 < np.median(r.coherence[0, band]) < 1.0
    # the errors (block: Bendat & Piersol from the coherence, n_d = 6; driven: the local
    # fits' residuals and the spread between bursts) match the actual scatter
    z = (r.h[0, band] - closed_frf(r.freq_hz[band], False, 1, fs)) / r.std[0, band]
    assert 0.7 < np.sqrt(np.mean(np.abs(z) ** 2) / 2) < 1.4


@pytest.mark.parametrize("mode,text", [("block", "4 burst block(s)"), ("driven", "4 impulse block(s)")])
def test_an_impact_is_answered_through_its_whole_block(mode, text):
    """Hammer-like pulses 20 ms long every 16 s: the drive is far too short to hold the
    response, so each block runs from the hit through the free decay, unwindowed (the
    driven option too)."""
    fs = 256.0
    pulse = np.hanning(7)
    u = np.zeros(1 << 14)
    for a in (0, 1 << 12, 2 << 12, 3 << 12):
        u[a + 10:a + 17] = 50.0 * pulse
    v = simulate(u, fs, shaker=False)["v2"]
    r = estimate(u, v[None], fs, burst=mode)
    assert text in r.method
    band = (r.freq_hz > 5) & (r.freq_hz < 60)
    assert np.median(np.abs(r.h[0, band] / closed_frf(r.freq_hz[band], False, 1, fs) - 1)) < 2e-3


def test_an_unknown_burst_estimator_is_refused_by_name():
    u = np.concatenate([np.random.default_rng(1).normal(size=4096), np.zeros(4096)])
    with pytest.raises(InputError, match=r"'burst': must be one of block, driven .* got 'lrm'"):
        estimate(u, u[None], 256.0, burst="lrm")


def test_bendat_piersol_error_matches_the_scatter():
    fs, n = 256.0, 1 << 16
    rng = np.random.default_rng(11)
    u = rng.normal(size=n)
    y = np.convolve(u, [0.5, 0.3, -0.2], "same") + 0.5 * rng.normal(size=n)
    r = estimate(u, y[None], fs, nperseg=256, overlap=0.5)
    h = np.fft.rfft([0.5, 0.3, -0.2], 256)  # the FIR filter, centred: phase from the lag
    ref = h[1:r.freq_hz.size + 1] * np.exp(2j * np.pi * r.freq_hz / fs)
    z = np.abs(r.h[0] - ref) / r.std[0]
    assert 0.9 < np.sqrt(np.mean(z ** 2) / 2) < 1.15


def test_a_steady_sine_is_not_broadband():
    t = np.arange(8192) / 256.0
    with pytest.raises(InputError, match="not broadband"):
        estimate(np.sin(2 * np.pi * 20 * t), np.ones((1, t.size)), 256.0)


def test_a_segment_longer_than_the_data_is_refused_naming_nperseg_and_its_range():
    rng = np.random.default_rng(0)
    with pytest.raises(InputError, match=r"'nperseg': must be .* from 16 to 64 \(the record's"):
        estimate(rng.normal(size=64), np.ones((1, 64)), 100.0, method="welch", nperseg=128)
    # a burst record (its method takes no segments) never swallows an impossible one
    u = np.concatenate([rng.normal(size=4096), np.zeros(4096)])
    with pytest.raises(InputError, match=r"'nperseg': .* 16 to 8192 .* got 16777216"):
        estimate(u, u[None], 256.0, nperseg=1 << 24)
    with pytest.raises(InputError, match=r"'nperseg': .* 16 to 4[01]\d\d \(the active drive's"):
        estimate(u, u[None], 256.0, method="welch", nperseg=6000)
    with pytest.raises(InputError, match="'nperseg'"):
        estimate(u, u[None], 256.0, method="welch", nperseg=8)


def test_frfset_keeps_old_files_and_carries_drive_and_coherence(tmp_path):
    old = {"format": "labjoint.frfset/1", "frequencies_hz": [10.0], "level_n": [1.0],
           "direction": ["up"], "force": [[1.0, 0.0]], "sensors": ["a"],
           "response": [[[[1.0, 0.0]]]], "response_std": [[[0.1]]]}
    s = FrfSet.from_dict(old)
    assert s.drive_quantity == "force" and s.units == "m/s^2/N" and s.coherence is None
    fs = 256.0
    u = np.random.default_rng(2).normal(size=1 << 14)
    y = simulate(u, fs, shaker=True)
    b = frfset_from_arrays(u, "voltage", {"v2": ("velocity", y["v2"])}, fs, level=0.25, run="x")
    b.save(tmp_path / "f.json")
    back = FrfSet.load(tmp_path / "f.json")
    assert back == b and back.units == "m/s/V" and back.level_units == "V"
    assert back.to_dict()["level_units"] == "V"


def test_h1_h2_hv_against_noise_on_either_side(tmp_path):
    """Noise on the drive biases H1 low by the noise's share (|H1| = |H| / (1 + N/S)) and
    leaves H2 unbiased; noise on the response the other way; Hv lies between. The set
    keeps all three."""
    fs, n = 256.0, 1 << 17
    rng = np.random.default_rng(21)
    f = rng.normal(size=n)
    y = 2.0 * f
    r = estimate(f + 0.5 * rng.normal(size=n), y[None], fs, method="welch", nperseg=256)
    band = r.freq_hz > 1
    h1, h2, hv = (np.median(np.abs(r.alternatives[k][0, band])) for k in ("H1", "H2", "Hv"))
    assert h1 == pytest.approx(2.0 / 1.25, rel=0.02) and h2 == pytest.approx(2.0, rel=0.02)
    assert h1 < hv < h2
    r = estimate(f, (y + 1.0 * rng.normal(size=n))[None], fs, method="welch", nperseg=256)
    h1, h2 = (np.median(np.abs(r.alternatives[k][0, r.freq_hz > 1])) for k in ("H1", "H2"))
    assert h1 == pytest.approx(2.0, rel=0.02) and h2 == pytest.approx(2.0 * 1.25, rel=0.02)
    s = frfset_from_arrays(f, "force", {"y": ("displacement", y + rng.normal(size=n))}, fs,
                           estimator="H2", method="welch", nperseg=256)
    s.save(tmp_path / "s.json")
    back = FrfSet.load(tmp_path / "s.json")
    assert back.estimator == "H2" and set(back.alternatives) == {"H1", "Hv"} and back == s


def _assert_closed_form_velocity(r, fs: float) -> None:
    """The one-burst estimate ``r`` of v2 against the 2-DOF system's closed-form FRF (median
    error 1e-3 over 2-100 Hz) and its modes (frequency 1e-3, damping 2 %)."""
    band = (r.freq_hz > 2) & (r.freq_hz < 100)
    want = closed_frf(r.freq_hz[band], False, 1, fs)
    assert np.median(np.abs(r.h[0, band] / want - 1)) < 1e-3
    modes = find_modes(r.freq_hz, r.h, "velocity", ["v2"], (5.0, 60.0))
    for m, (fn, z) in zip(modes, closed_modes(False)):
        assert m["frequency_hz"] == pytest.approx(fn, rel=1e-3)
        assert m["damping_ratio"] == pytest.approx(z, rel=0.02)
