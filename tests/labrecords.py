"""Lab-like records of a known joint, written as the CSV import format (not the simulated rig).

The joint: a Jenkins element (spring k_s in series with a Coulomb slider f_s) in parallel
with a spring k_p, i.e. the model ``linear_stiffness+coulomb``, plus at most one hidden
effect (``viscous`` c, ``cubic_stiffness`` k3 or ``inertia`` m). The record carries what
a lab's does, all at once: rest before and after, raised-cosine ramps up and down, a DC
displacement offset (a capacitive sensor's gap), mains hum on the force channel, white
noise on both channels and 24-bit quantisation of both (a +-10 V DAQ input through the
sensors' factors). Used by the diagnosis tests and ``benchmarks/bench_null_cases.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

FS = 20000.0
#: hidden effects and the size that makes each clearly visible at these noise levels
EFFECTS = {"viscous": ("c", 60.0), "cubic_stiffness": ("k3", 1.5e16), "inertia": ("m", 0.015)}


@dataclass
class LabCase:
    """One set of runs: the joint, the hidden effect (or none) and the artefacts."""

    seed: int
    effect: str | None = None
    k_s: float = 12e6
    f_s: float = 50.0
    k_p: float = 2e6
    frequencies: tuple[float, ...] = (200.0, 450.0)
    amplitudes: tuple[float, ...] = (3e-6, 6e-6, 9e-6)
    cycles: int = 40
    ramp_cycles: int = 8
    rest_s: float = 0.03
    hum_n: float = 1.0
    hum_hz: float = 50.0
    gap_m: float = 30e-6
    noise_m: float = 5e-9
    noise_n: float = 0.3
    params: dict[str, float] = field(default_factory=dict)

    @classmethod
    def draw(cls, seed: int, effect: str | None = None) -> "LabCase":
        """A random case: joint, frequencies, levels and artefacts drawn from ``seed``."""
        rng = np.random.default_rng(seed)
        f1 = float(rng.uniform(150.0, 300.0))
        f2 = float(rng.uniform(400.0, 700.0))
        params = {}
        if effect is not None:
            name, size = EFFECTS[effect]
            params[name] = size * float(rng.uniform(0.8, 1.5))
        return cls(seed=seed, effect=effect, k_s=float(rng.uniform(8e6, 16e6)),
                   f_s=float(rng.uniform(35.0, 70.0)), k_p=float(rng.uniform(1e6, 4e6)),
                   frequencies=(round(f1, 1), round(f2, 1)),
                   hum_n=float(rng.uniform(0.3, 2.0)), hum_hz=float(rng.choice([50.0, 60.0])),
                   gap_m=float(rng.uniform(10e-6, 60e-6)), rest_s=float(rng.uniform(0.01, 0.05)),
                   ramp_cycles=int(rng.integers(4, 12)), params=params)

    def write(self, directory: Path) -> list[Path]:
        """One CSV per frequency and amplitude; returns the paths."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        paths = []
        for i, f in enumerate(self.frequencies):
            for j, U in enumerate(self.amplitudes):
                p = directory / f"lab{self.seed}_{f:g}Hz_{U * 1e6:g}um.csv"
                self._write_run(p, f, U, self.seed * 1000 + 10 * i + j)
                paths.append(p)
        return paths

    def force(self, u: np.ndarray) -> np.ndarray:
        """Joint force (N) for the displacement history ``u`` sampled at FS."""
        dt = 1.0 / FS
        v = np.gradient(u, dt)
        a = np.gradient(v, dt)
        q, F = 0.0, np.empty(u.size)
        du = np.diff(u, prepend=0.0)
        for i in range(u.size):
            q = min(max(q + self.k_s * du[i], -self.f_s), self.f_s)
            F[i] = q
        F += self.k_p * u
        F += self.params.get("c", 0.0) * v + self.params.get("k3", 0.0) * u ** 3
        F += self.params.get("m", 0.0) * a
        return F

    def _write_run(self, path: Path, f: float, U: float, seed: int) -> None:
        rng = np.random.default_rng(seed)
        period = 1.0 / f
        n_ramp = self.ramp_cycles * period
        t_on = self.rest_s
        t_steady = t_on + n_ramp
        t_down = t_steady + self.cycles * period
        t_off = t_down + n_ramp
        n = int(round((t_off + self.rest_s) * FS))
        t = np.arange(n) / FS
        env = np.zeros(n)
        up = (t >= t_on) & (t < t_steady)
        env[up] = 0.5 * (1 - np.cos(np.pi * (t[up] - t_on) / n_ramp))
        env[(t >= t_steady) & (t < t_down)] = 1.0
        down = (t >= t_down) & (t < t_off)
        env[down] = 0.5 * (1 + np.cos(np.pi * (t[down] - t_down) / n_ramp))
        u = U * env * (np.sin(2 * np.pi * f * (t - t_on)) + 0.02 * np.sin(6 * np.pi * f * (t - t_on) + 0.3))
        F = self.force(u)
        um = u + self.gap_m + rng.normal(0.0, self.noise_m, n)
        hum = self.hum_n * np.sin(2 * np.pi * self.hum_hz * t + rng.uniform(0, 2 * np.pi))
        Fm = F + hum + rng.normal(0.0, self.noise_n, n)
        um = _quantise(um, 10.0 / 8.0e4)          # 80 V/mm capacitive sensor, +-10 V
        Fm = _quantise(Fm, 10.0 * 50.0)           # 50 N/V force sensor, +-10 V
        with open(path, "w") as fh:
            fh.write("# torque_nm: 5\n# source: lab-like generator (tests/labrecords.py)\n"
                     "time_s,displacement_m,force_N\n")
            np.savetxt(fh, np.column_stack([t, um, Fm]), fmt="%.10g", delimiter=",")


def _quantise(x: np.ndarray, full_scale: float, bits: int = 24) -> np.ndarray:
    """Round to the LSB of a +-full_scale range of ``bits`` bits."""
    lsb = 2.0 * full_scale / 2 ** bits
    return np.round(x / lsb) * lsb
