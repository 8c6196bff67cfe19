"""The compiled per-cycle kernel (identify.loop.loop_metrics, the hot loop of `labjoint
analyze`) against a plain numpy computation written here, to 1e-12 of each quantity's
scale: speed work on the kernel (issue 31 item 4) must not move the numbers."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.identify.loop import loop_metrics

FS, F0 = 50_000.0, 400.0


def reference(u: np.ndarray, F: np.ndarray, bounds: np.ndarray, m: int, h: int) -> dict:
    """Catmull-Rom resampling at m points per cycle, then the loop quantities in numpy."""
    k = np.arange(bounds.size - 1)[:, None]
    t = bounds[k] + np.arange(m)[None, :] * (bounds[k + 1] - bounds[k]) / m
    i = np.floor(t).astype(int)
    s = t - i
    w = [0.5 * s * (-1 + s * (2 - s)), 1 + 0.5 * s * s * (-5 + 3 * s),
         0.5 * s * (1 + s * (4 - 3 * s)), 0.5 * s * s * (s - 1)]

    def resample(x):
        return sum(wj * x[i - 1 + j] for j, wj in enumerate(w))

    ub, fb = resample(u), resample(F)
    du, df = ub - ub[:, :1], fb - fb[:, :1]
    area = 0.5 * np.sum(df * np.roll(du, -1, axis=1) - np.roll(df, -1, axis=1) * du, axis=1)
    uc, fc = ub - ub.mean(axis=1, keepdims=True), fb - fb.mean(axis=1, keepdims=True)
    return {"energy_loss": area,
            "displacement_amplitude": 0.5 * np.ptp(ub, axis=1),
            "force_amplitude": 0.5 * np.ptp(fb, axis=1),
            "stiffness_lsq": np.sum(uc * fc, axis=1) / np.sum(uc * uc, axis=1),
            "displacement_harmonics": np.fft.rfft(ub, axis=1)[:, 1:h + 1] * 2 / m,
            "force_harmonics": np.fft.rfft(fb, axis=1)[:, 1:h + 1] * 2 / m}


@pytest.mark.parametrize("m", [256, 255, 64])
def test_kernel_matches_numpy_to_1e_12(m: int) -> None:
    rng = np.random.default_rng(31)
    t = np.arange(int(0.5 * FS)) / FS
    u = 9e-6 * np.sin(2 * np.pi * F0 * t) + 2e-4 + 1e-8 * rng.standard_normal(t.size)
    # a dissipative loop with a third harmonic and noise: k u + c du/dt + ...
    F = (1e7 * (u - 2e-4) + 600.0 * 9e-6 * 2 * np.pi * F0 * np.cos(2 * np.pi * F0 * t)
         + 3.0 * np.sin(6 * np.pi * F0 * t) + 0.4 * rng.standard_normal(t.size) + 5.0)
    bounds = 2.3 + np.arange(int(0.5 * F0) - 2) * FS / F0 + 0.01 * rng.standard_normal(198)
    got = loop_metrics(u, F, bounds, F0, m, 5)
    ref = reference(u, F, bounds, m, 5)
    for name, want in ref.items():
        scale = np.abs(want).max()
        assert np.max(np.abs(got[name] - want)) <= 1e-12 * scale, name
    # and the loop is what it should be: W = pi c omega U^2 for the viscous part
    w_visc = np.pi * 600.0 * 2 * np.pi * F0 * 9e-6 ** 2
    assert np.median(got["energy_loss"]) == pytest.approx(w_visc, rel=0.02)
