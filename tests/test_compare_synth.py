"""Closed-form synthetic runs for the model-comparison tests (and checks of the generator).

Displacement u = U sin(2 pi f t + phi0) sampled exactly; force from closed forms of the
vocabulary laws on that displacement (k u, c du/dt = c U w cos, k3 u^3, F0, m d2u/dt2),
plus Gaussian noise on force and displacement, as a measured run would carry.
"""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.storage import Run

FS = 25600.0


def synth_run(name: str, f: float, U: float, *, k: float = 1e7, c: float = 0.0, k3: float = 0.0,
              F0: float = 0.0, m: float = 0.0, noise_f: float = 0.3, noise_u: float = 0.0,
              cycles: int = 30, phi0: float = 0.3, drift: float = 0.0, seed: int = 0,
              extra=None) -> Run:
    """A steady synthetic run (SI). ``drift``: relative change of the force amplitude over
    the record (slow, linear); ``extra(t, u, v)``: an added force."""
    rng = np.random.default_rng(seed)
    n = int(round(cycles * FS / f))
    t = np.arange(n) / FS
    w = 2 * np.pi * f
    u = U * np.sin(w * t + phi0)
    v = U * w * np.cos(w * t + phi0)
    a = -w * w * u
    F = k * u + c * v + k3 * u ** 3 + F0 + m * a
    if extra is not None:
        F = F + extra(t, u, v)
    F = F * (1.0 + drift * (t / t[-1] - 0.5))
    F = F + noise_f * rng.standard_normal(n)
    um = u + noise_u * rng.standard_normal(n)
    return Run(name=name, time=t, displacement=um, force=F,
               metadata={"frequency_hz": f, "sample_rate_hz": FS})


def sweep(freqs=(200.0, 400.0, 800.0), amps=(2e-6, 5e-6, 1e-5), **kw) -> list[Run]:
    """One run per (frequency, amplitude), distinct noise seeds."""
    out = []
    for i, f in enumerate(freqs):
        for j, U in enumerate(amps):
            out.append(synth_run(f"s{f:g}Hz_{U * 1e6:g}um", f, U, seed=10 * i + j, **kw))
    return out


def write_csv(path, run: Run) -> None:
    """The run as a CSV file in the import format (design.md)."""
    with open(path, "w") as fh:
        fh.write(f"# frequency_hz: {run.metadata['frequency_hz']}\n")
        fh.write(f"# sample_rate_hz: {FS}\n")
        fh.write("time_s,displacement_m,force_N\n")
        np.savetxt(fh, np.column_stack([run.time, run.displacement, run.force]), fmt="%.10g",
                   delimiter=",")


def test_synthetic_run_follows_its_closed_form():
    r = synth_run("a", 400.0, 5e-6, k=1e7, c=100.0, noise_f=0.0)
    w = 2 * np.pi * 400.0
    # the loop area of k u + c v over one cycle is pi c w U^2 (seed 002 Eq. 1)
    per = int(FS / 400.0)
    u, F = r.displacement[:per + 1], r.force[:per + 1]
    area = np.sum(0.5 * (F[1:] + F[:-1]) * np.diff(u))
    # trapezoid over M = 64 points: low by M sin(2 pi / M) / (2 pi) = 1 - 1.6e-3
    assert area == pytest.approx(np.pi * 100.0 * w * 25e-12 * 64 * np.sin(2 * np.pi / 64) / (2 * np.pi), rel=1e-6)
