"""A force that does not excite the band the model needs gets a warning in the result
(issue 14, bad input): an oscillator driven only above its resonance has its stiffness
unsupported by the data; driven across it, no warning."""

import numpy as np
import pytest

from labjoint.compare.identifiability import band_warnings, resonance_hz
from labjoint.compare.output_error import fit_simulation
from labjoint.models.simulate import simulate
from labjoint.storage import Run

FS, N = 750.0, 1024
EXPR = "inertia+viscous+linear_stiffness"
TRUE = {"inertia.m": 2.0, "viscous.c": 10.0, "linear_stiffness.k": 5e4}     # 25.2 Hz


def record(f_lo, f_hi, seed=1, periods=4):
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(N, 1 / FS)
    u = np.fft.irfft(np.where((f >= f_lo) & (f <= f_hi), np.exp(2j * np.pi * rng.random(f.size)), 0), N)
    F = np.tile(u * 50.0 / np.std(u), periods)
    y = simulate(EXPR, TRUE, F, FS) + 1e-9 * rng.standard_normal(F.size)
    return Run(f"r{f_lo}", np.arange(F.size) / FS, y, F, {"sample_rate_hz": FS})


def test_driven_only_above_resonance_the_fit_warns_that_stiffness_is_unsupported():
    fit = fit_simulation([record(80, 200)], EXPR)
    (w,) = fit.to_dict()["warnings"]
    assert "outside the band" in w and "stiffness" in w


def test_driven_across_the_resonance_there_is_no_warning():
    fit = fit_simulation([record(5, 150)], EXPR)
    assert fit.to_dict()["warnings"] == []
    assert fit.params["linear_stiffness.k"].value == pytest.approx(5e4, rel=1e-3)


def test_band_rule_names_the_mass_when_the_force_stays_below_resonance():
    t = np.arange(8192) / FS
    (w,) = band_warnings([np.sin(2 * np.pi * 5 * t)], [FS], TRUE)
    assert "mass" in w and "25.16 Hz" in w
    assert resonance_hz({"linear_stiffness.k": 1.0}) is None
