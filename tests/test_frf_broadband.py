"""Broadband FRFs and modes against closed forms: a 2-DOF system integrated here (scipy
lsim), measured in acceleration and velocity, driven by a force and by a voltage through a
shaker (coil: L di/dt + R i + Bl v = V, force Bl i); random and multisine drives."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from labjoint.errors import InputError
from labjoint.identify.modes import find_modes
from labjoint.signal.broadband import estimate
from labjoint.signal.frf_levels import frfset_from_arrays
from labjoint.signal.frfset import FrfSet

M = np.diag([1.0, 0.5])
K = np.array([[3.0e4, -1.5e4], [-1.5e4, 1.5e4]])
C = 2e-4 * K + 0.5 * M                      # proportional: real modes
BL, R, L = 10.0, 2.0, 2e-3


def _state(shaker: bool) -> tuple[np.ndarray, np.ndarray]:
    """x' = A x + B u; states x1, x2, v1, v2 (+ coil current); u a force or a voltage."""
    Mi = np.linalg.inv(M)
    n = 5 if shaker else 4
    A = np.zeros((n, n))
    A[:2, 2:4] = np.eye(2)
    A[2:4, :2], A[2:4, 2:4] = -Mi @ K, -Mi @ C
    B = np.zeros((n, 1))
    if shaker:
        A[2:4, 4] = Mi[:, 0] * BL             # coil force on mass 1
        A[4, 2], A[4, 4] = -BL / L, -R / L    # back EMF, resistance
        B[4, 0] = 1 / L
    else:
        B[2:4, 0] = Mi[:, 0]
    return A, B


def _modes(A: np.ndarray) -> list[tuple[float, float]]:
    lam = np.linalg.eigvals(A)
    lam = lam[(lam.imag > 0)]
    return sorted((abs(p) / (2 * np.pi), -p.real / abs(p)) for p in lam)


def _simulate(u: np.ndarray, fs: float, shaker: bool) -> dict[str, np.ndarray]:
    A, B = _state(shaker)
    n = A.shape[0]
    Cm = np.vstack([np.eye(n)[2:4], A[2:4]])          # velocities, accelerations
    Dm = np.vstack([np.zeros((2, 1)), B[2:4]])
    t = np.arange(u.size) / fs
    _, y, _ = sps.lsim((A, B, Cm, Dm), u, t)
    return {"v2": y[:, 1], "a1": y[:, 2], "a2": y[:, 3]}


def _closed(f: np.ndarray, shaker: bool, out: int, fs: float) -> np.ndarray:
    """The sampled system's FRF: lsim holds the input linearly between samples, so the
    closed form is the first-order-hold discretisation's H(z) at z = exp(i w / fs)."""
    A, B = _state(shaker)
    n = A.shape[0]
    Ad, Bd, Cd, Dd, _ = sps.cont2discrete((A, B, np.eye(n)[[2 + out]], np.zeros((1, 1))), 1 / fs, "foh")
    z = np.exp(2j * np.pi * f / fs)
    return np.array([(Cd @ np.linalg.solve(zi * np.eye(n) - Ad, Bd))[0, 0] + Dd[0, 0] for zi in z])


@pytest.mark.parametrize("shaker", [False, True])
def test_random_drive_modes_within_a_tenth_of_a_percent(shaker):
    fs, n = 256.0, 1 << 17
    rng = np.random.default_rng(3)
    u = rng.normal(size=n) * (0.2 if shaker else 10.0)
    y = _simulate(u, fs, shaker)
    s = frfset_from_arrays(u, "voltage" if shaker else "force",
                           {"v2": ("velocity", y["v2"]), "a1": ("acceleration", y["a1"]),
                            "a2": ("acceleration", y["a2"])}, fs, run="r")
    assert s.units == ("m/s/V" if shaker else "m/s/N") and s.quantity == "velocity"
    assert s.metadata["converted"] == {"a1": "acceleration -> velocity", "a2": "acceleration -> velocity"}
    h = s.response[:, :, 0].T
    modes = find_modes(s.frequencies_hz, h, s.quantity, s.sensors, (5.0, 60.0))
    want = _modes(_state(shaker)[0])
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
    y = _simulate(u, fs, shaker=True)
    r = estimate(u, np.vstack([y["v2"], y["a1"]]), fs)
    assert "steady periods" in r.method and r.freq_hz.size == k.size
    want = _closed(r.freq_hz, True, 1, fs)
    assert np.max(np.abs(r.h[0] / want - 1)) < 1e-3
    noisy = y["v2"] + 1e-4 * rng.normal(size=u.size)
    r2 = estimate(u, noisy[None], fs)
    z = (r2.h[0] - want) / r2.std[0]
    assert 0.6 < np.std(np.concatenate([z.real, z.imag])) < 1.5


def test_a_burst_and_its_free_decay_form_one_unwindowed_block():
    """One 32 s burst, then 32 s of rest: the block holds the burst's whole response, so
    H1 is the sampled system's FRF (no window, no leakage) wherever the drive has power."""
    fs = 256.0
    rng = np.random.default_rng(7)
    u = np.concatenate([rng.normal(size=1 << 13), np.zeros(1 << 13)])
    y = _simulate(u, fs, shaker=False)
    r = estimate(u, y["v2"][None] + 1e-6 * rng.normal(size=u.size), fs)
    assert r.method.startswith("H1 over 1 burst block") and r.averages == 1
    assert r.active_s[1] == pytest.approx(32.0, abs=0.1)
    band = (r.freq_hz > 2) & (r.freq_hz < 100)
    want = _closed(r.freq_hz[band], False, 1, fs)
    assert np.median(np.abs(r.h[0, band] / want - 1)) < 1e-3
    modes = find_modes(r.freq_hz, r.h, "velocity", ["v2"], (5.0, 60.0))
    for m, (fn, z) in zip(modes, _modes(_state(False)[0])):
        assert m["frequency_hz"] == pytest.approx(fn, rel=1e-3)
        assert m["damping_ratio"] == pytest.approx(z, rel=0.02)


def test_several_bursts_are_averaged_with_their_coherence():
    fs = 256.0
    rng = np.random.default_rng(8)
    on, off = 1 << 12, 1 << 12
    u = np.concatenate([np.concatenate([rng.normal(size=on), np.zeros(off)]) for _ in range(6)])
    v = _simulate(u, fs, shaker=False)["v2"]
    y = v + 0.05 * v.std() * rng.normal(size=u.size)
    r = estimate(u, y[None], fs)
    assert r.averages == 6 and "6 burst block(s)" in r.method
    band = (r.freq_hz > 5) & (r.freq_hz < 60)
    assert 0.5 < np.median(r.coherence[0, band]) < 1.0
    # the errors from the coherence (Bendat & Piersol, n_d = 6) match the actual scatter
    z = (r.h[0, band] - _closed(r.freq_hz[band], False, 1, fs)) / r.std[0, band]
    assert 0.7 < np.sqrt(np.mean(np.abs(z) ** 2) / 2) < 1.4


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


def test_a_record_shorter_than_a_segment_is_refused():
    with pytest.raises(InputError, match="fewer than one segment"):
        estimate(np.random.default_rng(0).normal(size=64), np.ones((1, 64)), 100.0,
                 method="welch", nperseg=128)


def test_frfset_keeps_old_files_and_carries_drive_and_coherence(tmp_path):
    old = {"format": "labjoint.frfset/1", "frequencies_hz": [10.0], "level_n": [1.0],
           "direction": ["up"], "force": [[1.0, 0.0]], "sensors": ["a"],
           "response": [[[[1.0, 0.0]]]], "response_std": [[[0.1]]]}
    s = FrfSet.from_dict(old)
    assert s.drive_quantity == "force" and s.units == "m/s^2/N" and s.coherence is None
    fs = 256.0
    u = np.random.default_rng(2).normal(size=1 << 14)
    y = _simulate(u, fs, shaker=True)
    b = frfset_from_arrays(u, "voltage", {"v2": ("velocity", y["v2"])}, fs, level=0.25, run="x")
    b.save(tmp_path / "f.json")
    back = FrfSet.load(tmp_path / "f.json")
    assert back == b and back.units == "m/s/V" and back.level_units == "V"
    assert back.to_dict()["level_units"] == "V"
