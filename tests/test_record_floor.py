"""Record-kind diagnosis does not invent effects on exact models (issue 33 item 8), on
records of a generator written here (band-limited random and multisine signals, the
force or the response in closed form line by line):

(a) a viscous + linear joint driven by a random displacement, 15 nm of displacement
    noise: the noise floor carries that noise through c du/dt, so the model is adequate;
(b) an inertia + viscous + linear oscillator (m 2 kg, c 10 N s/m, k 5e4 N/m) under a
    multisine force, 0.5 % noise on both channels: the default equation error fits m and
    k within a few % and to its floor, naming nothing (no channel_delay), and so does the
    simulation error.
"""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.compare import diagnose_runs
from labjoint.compare.output_error import fit_simulation
from labjoint.storage import Run
from scipy.signal import lsim

M, C, K = 2.0, 10.0, 5e4


def _band(n, fs, lo, hi, rng):
    f = np.fft.rfftfreq(n, 1 / fs)
    spec = np.where((f >= lo) & (f <= hi),
                    rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size), 0)
    return f, spec


def joint_record(seed=0, noise_u=15e-9):
    """(a): u random 50-800 Hz, 1 um rms; F = k u + c du/dt exactly (du/dt line by line)."""
    rng = np.random.default_rng(seed)
    fs, n = 10000.0, 40000
    f, spec = _band(n, fs, 50, 800, rng)
    g = 1e-6 / np.std(np.fft.irfft(spec, n))
    u = np.fft.irfft(spec, n) * g
    v = np.fft.irfft(spec * 2j * np.pi * f, n) * g
    F = 1e7 * u + 1e3 * v
    F = F + 0.002 * np.std(F) * rng.standard_normal(n)
    u = u + noise_u * rng.standard_normal(n)
    return Run("joint", np.arange(n) / fs, u, F, {"sample_rate_hz": fs})


def oscillator_record(seed=0, periods=4, noise=0.005):
    """(b): a multisine force 5-150 Hz (periods of 2 s) switched on after 0.2 s at rest,
    and the oscillator's response from rest (scipy's lsim of m y'' + c y' + k y = F);
    Gaussian noise of ``noise`` x each channel's rms."""
    rng = np.random.default_rng(seed)
    fs, n = 5000.0, 10000
    f, spec = _band(n, fs, 5, 150, rng)
    spec = np.where(spec != 0, np.exp(1j * np.angle(spec)), 0)
    g = 50.0 / np.std(np.fft.irfft(spec, n))
    F = np.concatenate([np.zeros(int(0.2 * fs)), np.tile(np.fft.irfft(spec, n) * g, periods)])
    t = np.arange(F.size) / fs
    _, u, _ = lsim(([1.0], [M, C, K]), F, t)
    F = F + noise * np.std(F) * rng.standard_normal(F.size)
    u = u + noise * np.std(u) * rng.standard_normal(u.size)
    return Run("oscillator", t, u, F, {"sample_rate_hz": fs})


def test_displacement_noise_through_the_damper_is_in_the_floor():
    res = diagnose_runs([joint_record()], "linear_stiffness+viscous", kind="record")
    assert res["adequate"], res["verdict"]
    assert res["nrmse"] <= 1.2 * res["noise_floor"]
    # the force noise alone (0.2 %) is far below what the displacement noise adds
    assert res["noise_floor"] > 0.005
    p = res["parameters"]
    assert p["viscous.c"]["value"] == pytest.approx(1e3, rel=0.02)


def test_an_exact_oscillator_fits_to_its_floor_by_equation_error_and_names_nothing():
    res = diagnose_runs([oscillator_record()], "inertia+viscous+linear_stiffness", kind="record")
    assert res["adequate"], res["verdict"]
    assert "channel_delay" not in res["verdict"]
    assert res["nrmse"] <= 1.2 * res["noise_floor"]
    p = {k: v["value"] for k, v in res["parameters"].items()}
    assert p["inertia.m"] == pytest.approx(M, rel=0.03)
    assert p["linear_stiffness.k"] == pytest.approx(K, rel=0.03)


def test_an_exact_oscillator_fits_to_its_floor_by_simulation_error():
    fit = fit_simulation([oscillator_record()], "inertia+viscous+linear_stiffness")
    assert fit.nrmse() <= 1.3 * fit.noise_floor()
    assert fit.params["inertia.m"].value == pytest.approx(M, rel=0.03)
    assert fit.params["linear_stiffness.k"].value == pytest.approx(K, rel=0.03)
