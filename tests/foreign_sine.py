"""An independent generator of steady-sine joint records (numpy only, not labjoint's
simulator) with closed-form answers, written as another lab's CSV would be.

- linear joint F = k u + c du/dt: W = pi c omega U^2, C = c, stiffness k;
- Jenkins element (spring k in series with a Coulomb slider f_s), U > f_s / k:
  W = 4 f_s (U - f_s / k) per cycle;
- cubic stiffness F = k u + k3 u^3: W = 0.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

HEADER = ("time_s", "displacement_m", "force_N")


def jenkins(u: np.ndarray, k: float, f_s: float) -> np.ndarray:
    """Force of a spring k in series with a Coulomb slider f_s along ``u`` (starts stuck)."""
    out, q, prev = np.empty_like(u), 0.0, u[0]
    for i, x in enumerate(u):
        q = min(max(q + k * (x - prev), -f_s), f_s)
        prev = x
        out[i] = q
    return out


@dataclass(frozen=True)
class Record:
    """One record: the joint, the drive, and what a foreign lab's file adds."""

    joint: str = "linear"            # linear | jenkins | cubic
    f: float = 100.0                 # drive frequency (Hz)
    fs: float = 25600.0              # sample rate (Hz)
    U: float = 5e-6                  # displacement amplitude (m)
    cycles: float = 30.0
    k: float = 2e6
    c: float = 300.0
    f_s: float = 20.0
    k3: float = 1e15
    phase0: float = 0.7              # the record starts mid-cycle
    ramp_cycles: float = 0.0         # a start-up transient (linear ramp of the amplitude)
    offset_u: float = 0.0
    offset_f: float = 0.0
    drift_u: float = 0.0             # m/s
    drift_f: float = 0.0             # N/s
    hum: float = 0.0                 # N, on the force
    hum_hz: float = 50.0
    noise_u: float = 0.0             # m rms
    noise_f: float = 0.0             # N rms
    t0: float = 0.0
    seed: int = 0

    def but(self, **kw) -> "Record":
        return replace(self, **kw)

    @property
    def energy_loss(self) -> float:
        """Closed-form W per cycle (J)."""
        if self.joint == "linear":
            return float(np.pi * self.c * 2 * np.pi * self.f * self.U ** 2)
        if self.joint == "jenkins":
            return float(4 * self.f_s * (self.U - self.f_s / self.k))
        return 0.0

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(time s, measured displacement m, measured force N)."""
        rng = np.random.default_rng(self.seed)
        n = int(round(self.cycles * self.fs / self.f))
        t = np.arange(n) / self.fs
        w = 2 * np.pi * self.f
        env = np.clip(t * self.f / self.ramp_cycles, 0, 1) if self.ramp_cycles else 1.0
        denv = (np.where(t * self.f < self.ramp_cycles, self.f / self.ramp_cycles, 0.0)
                if self.ramp_cycles else 0.0)
        u = self.U * env * np.sin(w * t + self.phase0)
        v = self.U * (env * w * np.cos(w * t + self.phase0) + denv * np.sin(w * t + self.phase0))
        if self.joint == "linear":
            F = self.k * u + self.c * v
        elif self.joint == "jenkins":
            F = jenkins(u, self.k, self.f_s)
        else:
            F = self.k * u + self.k3 * u ** 3
        um = u + self.offset_u + self.drift_u * t + rng.normal(0, 1, n) * self.noise_u
        Fm = (F + self.offset_f + self.drift_f * t + rng.normal(0, 1, n) * self.noise_f
              + self.hum * np.sin(2 * np.pi * self.hum_hz * t + 0.3))
        return t + self.t0, um, Fm


def write_csv(path: Path, t: np.ndarray, u: np.ndarray, F: np.ndarray,
              meta: dict | None = None, columns: tuple[str, ...] = HEADER,
              fmt: str = "%.12g") -> Path:
    """The design.md CSV import format (``# key: value`` lines, then a header row)."""
    data = dict(zip(HEADER, (t, u, F)))
    with open(path, "w") as fh:
        for key, value in (meta or {}).items():
            fh.write(f"# {key}: {value}\n")
        fh.write(",".join(columns) + "\n")
        np.savetxt(fh, np.column_stack([data[c] for c in columns]), fmt=fmt, delimiter=",")
    return path
