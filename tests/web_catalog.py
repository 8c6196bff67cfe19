"""Shared by the page tests (no tests here): a data directory such as a lab has after
months, fast to make: a thousand small imported CSV runs, a long run (40 s at 150 Hz),
runs of the simulated rig that were aborted, interrupted (closed incomplete) and
recorded for exactly 50 cycles."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from labjoint.storage import Catalog
from labjoint.storage.csv_import import import_csv
from test_api_helpers import write_sim_run

#: Runs in the big catalog.
BULK = 1000
#: The long run: its excitation, sample rate and length.
LONG_HZ, LONG_FS, LONG_S = 150.0, 3000.0, 40.0
#: Cycles recorded in the run whose cycle count the page must state.
CYCLES_50 = 50


def joint_csv(path: Path, f: float, fs: float, seconds: float, amp_m: float, *,
              k: float = 1e7, c: float = 300.0, seed: int = 0, start: str | None = None) -> Path:
    """A CSV in the import format: u = U sin(2 pi f t), F = k u + c du/dt + noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * fs))) / fs
    w = 2 * np.pi * f
    u = amp_m * np.sin(w * t)
    force = k * u + c * amp_m * w * np.cos(w * t) + 0.01 * k * amp_m * rng.standard_normal(t.size)
    head = [f"# frequency_hz: {f:g}", f"# sample_rate_hz: {fs:g}", "# torque_nm: 5",
            f"# excitation_vpp: {amp_m * 2e6:g}"] + ([f"# start_time: {start}"] if start else [])
    body = np.column_stack([t, u, force])
    with open(path, "w") as fh:
        fh.write("\n".join(head) + "\ntime_s,displacement_m,force_N\n")
        np.savetxt(fh, body, delimiter=",", fmt="%.9g")
    return path


def make_lab(data: Path, tmp: Path, bulk: int = BULK) -> dict[str, str]:
    """Fill ``data``; the names of the special runs by role."""
    cat = Catalog(data / "catalog.sqlite")
    for i in range(bulk):
        src = joint_csv(tmp / f"bulk_{i:04d}.csv", 100.0, 2000.0, 0.05, 1e-6 * (1 + i % 9),
                        seed=i, start=f"2025-01-{1 + i % 28:02d}T{i % 24:02d}:00:{i % 60:02d}Z")
        import_csv(src, data, catalog=cat)
    long = import_csv(joint_csv(tmp / "long_150Hz.csv", LONG_HZ, LONG_FS, LONG_S, 5e-6),
                      data, catalog=cat).stem
    fifty = write_sim_run(data, cat, "fifty_cycles", seconds=CYCLES_50 / 400.0, settle_s=0.2).stem
    aborted = write_sim_run(data, cat, "estopped", seconds=0.06, settle_s=0.2,
                            status="aborted").stem
    # the recording stopped without its RunStop: the run is closed "incomplete"
    write_sim_run(data, cat, "interrupted", seconds=0.06, settle_s=0.2, stop=False).close()
    return {"long": long, "fifty": fifty, "aborted": aborted, "incomplete": "interrupted"}
