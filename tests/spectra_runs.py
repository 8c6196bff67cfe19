"""Run files for the /spectra and broadband-FRF tests, from a generator written here (scipy lsim, not
labjoint's simulator): a 2-DOF chain (masses 1 and 0.5 kg) under a random force, and the
same chain driven by a voltage through a shaker coil (L di/dt + R i + Bl v = V, force
Bl i on mass 1); both masses measured (accelerations under the force, velocities under
the voltage); a steady sine through a known quadratic and cubic term. Closed-form modes
are the eigenvalues of the state matrix."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import signal as sps

from test_distortion_cli import _run_file

M = np.diag([1.0, 0.5])
K = np.array([[3.0e4, -1.5e4], [-1.5e4, 1.5e4]])
C = 2e-4 * K + 0.5 * M                      # proportional damping: real modes
BL, R, L = 10.0, 2.0, 2e-3
FS = 512.0


def state(shaker: bool) -> tuple[np.ndarray, np.ndarray]:
    """x' = A x + B u; states x1, x2, v1, v2 (+ coil current); u a force or a voltage."""
    Mi = np.linalg.inv(M)
    n = 5 if shaker else 4
    A = np.zeros((n, n))
    A[:2, 2:4] = np.eye(2)
    A[2:4, :2], A[2:4, 2:4] = -Mi @ K, -Mi @ C
    B = np.zeros((n, 1))
    if shaker:
        A[2:4, 4] = Mi[:, 0] * BL
        A[4, 2], A[4, 4] = -BL / L, -R / L
        B[4, 0] = 1 / L
    else:
        B[2:4, 0] = Mi[:, 0]
    return A, B


def closed_modes(shaker: bool) -> list[tuple[float, float]]:
    """(natural frequency Hz, damping ratio) of the structural poles, ascending."""
    lam = np.linalg.eigvals(state(shaker)[0])
    lam = lam[lam.imag > 0]
    return sorted((abs(p) / (2 * np.pi), -p.real / abs(p)) for p in lam)


def simulate(u: np.ndarray, fs: float, shaker: bool) -> dict[str, np.ndarray]:
    """Velocities v1, v2 and accelerations a1, a2 of the chain under ``u`` sampled at
    ``fs`` (lsim: the input held linearly between samples, from rest)."""
    A, B = state(shaker)
    n = A.shape[0]
    Cm = np.vstack([np.eye(n)[2:4], A[2:4]])
    Dm = np.vstack([np.zeros((2, 1)), B[2:4]])
    _, y, _ = sps.lsim((A, B, Cm, Dm), u, np.arange(u.size) / fs)
    return dict(zip(("v1", "v2", "a1", "a2"), y.T))


def closed_frf(f: np.ndarray, shaker: bool, out: int, fs: float) -> np.ndarray:
    """The sampled chain's FRF from ``u`` to velocity ``out`` (0, 1): lsim holds the input
    linearly between samples, so the closed form is the first-order-hold discretisation's
    H(z) at z = exp(i w / fs)."""
    A, B = state(shaker)
    n = A.shape[0]
    Ad, Bd, Cd, Dd, _ = sps.cont2discrete((A, B, np.eye(n)[[2 + out]], np.zeros((1, 1))), 1 / fs, "foh")
    z = np.exp(2j * np.pi * f / fs)
    return np.array([(Cd @ np.linalg.solve(zi * np.eye(n) - Ad, Bd))[0, 0] + Dd[0, 0] for zi in z])


def _response(u: np.ndarray, shaker: bool) -> tuple[np.ndarray, np.ndarray]:
    y = simulate(u, FS, shaker)
    return np.vstack([y["v1"], y["v2"]]), np.vstack([y["a1"], y["a2"]])   # velocities, accelerations


def random_force(path: Path, level_n: float, seed: int, n: int = 1 << 16, rest: float = 0.0) -> Path:
    """Band-limited random force (rms ``level_n``), accelerations of both masses; with
    ``rest`` > 0 one burst: the force is zero over the record's last ``rest`` share."""
    rng = np.random.default_rng(seed)
    b, a = sps.butter(4, 150.0, fs=FS)
    f = sps.lfilter(b, a, rng.normal(size=n))
    on = n - int(rest * n)
    f[on:] = 0.0
    f *= level_n / f[:on].std()
    _, acc = _response(f, False)
    acc = acc + 1e-4 * acc.std() * rng.normal(size=acc.shape)
    return _run_file(path, {"force": ("force", "N", f), "acc1": ("acceleration", "m/s^2", acc[0]),
                            "acc2": ("acceleration", "m/s^2", acc[1])}, FS, {"level": level_n})


def random_voltage(path: Path, level_v: float, seed: int, n: int = 1 << 16) -> Path:
    """Random amplifier voltage (rms ``level_v``) through the coil; velocities of both masses."""
    rng = np.random.default_rng(seed)
    b, a = sps.butter(4, 150.0, fs=FS)
    v = sps.lfilter(b, a, rng.normal(size=n))
    v *= level_v / v.std()
    vel, _ = _response(v, True)
    vel = vel + 1e-4 * vel.std() * rng.normal(size=vel.shape)
    return _run_file(path, {"amp": ("voltage", "V", v), "vel1": ("velocity", "m/s", vel[0]),
                            "vel2": ("velocity", "m/s", vel[1])}, FS, {"level": level_v})


#: the sine record's amplitude (V), frequency (Hz), quadratic and cubic terms
SINE_A, SINE_F, Q, CUBE = 0.8, 7.0, 0.05, 0.02


def sine_voltage(path: Path, n: int = 1 << 15) -> Path:
    """A steady sine voltage and a response y = u + Q u^2 + CUBE u^3 (m/s^2): h2/h1 and
    h3/h1 in closed form (:func:`sine_ratios`)."""
    t = np.arange(n) / FS
    u = SINE_A * np.sin(2 * np.pi * SINE_F * t)
    y = u + Q * u ** 2 + CUBE * u ** 3 + 1e-5 * np.random.default_rng(3).normal(size=n)
    return _run_file(path, {"amp": ("voltage", "V", u), "acc": ("acceleration", "m/s^2", y)}, FS)


def sine_ratios() -> dict[int, float]:
    """sin^2 = (1 - cos 2)/2, sin^3 = (3 sin - sin 3)/4."""
    h1 = SINE_A + 0.75 * CUBE * SINE_A ** 3
    return {2: Q * SINE_A ** 2 / 2 / h1, 3: CUBE * SINE_A ** 3 / 4 / h1}


def odd_multisine_cubic(path: Path, periods: int = 8, n: int = 2048) -> Path:
    """A random-odd multisine voltage (a third of the odd lines left out as detection
    lines) through a low-pass and a cubic term: odd distortion above the noise, no even."""
    rng = np.random.default_rng(4)
    k = np.arange(1, 300, 2)
    k = k[rng.random(k.size) > 0.3]
    U = np.zeros(n // 2 + 1, complex)
    U[k] = np.exp(2j * np.pi * rng.random(k.size))
    u1 = np.fft.irfft(U, n)
    u = np.tile(u1 / u1.std(), periods + 1)
    b, a = sps.butter(2, 0.2)
    x = sps.lfilter(b, a, u)
    y = x + 0.05 * x ** 3 + 1e-3 * rng.normal(size=x.size)
    return _run_file(path, {"amp": ("voltage", "V", u), "acc": ("acceleration", "m/s^2", y)}, FS)


def measured_modes(path: Path) -> dict:
    """`labjoint modes RUN --json` of a run file, as a user gets the modes."""
    import contextlib
    import io
    import json

    from labjoint.cli.main import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["modes", str(path), "--json"]) == 0
    return json.loads(out.getvalue())
