"""Independent generators of lab exports for the import tests: a 2-channel record (a
drive and a response with known closed-form samples) written as CSV, MATLAB v5/v7.3,
UFF 58, TDMS and multi-test HDF5, in the units labs use."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

FS = 512.0
N = 1024
T = np.arange(N) / FS
#: SI truth: a voltage drive, a velocity and an acceleration response, a force.
VOLTS = 0.2 * np.sin(2 * np.pi * 8.0 * T)
VELOCITY = 3e-3 * np.cos(2 * np.pi * 8.0 * T + 0.4)          # m/s
ACCEL = -2 * np.pi * 8.0 * 3e-3 * np.sin(2 * np.pi * 8.0 * T + 0.4)   # m/s^2
FORCE = 12.0 * np.sin(2 * np.pi * 8.0 * T + 0.1)              # N

MAP_HEAD = """
[time]
source = "{time}"
units = "{tunits}"
[channels.drive]
source = "{drive}"
quantity = "voltage"
units = "mV"
role = "drive"
[channels.laser]
source = "{vel}"
quantity = "velocity"
units = "mm/s"
[channels.acc]
source = "{acc}"
quantity = "acceleration"
units = "g"
"""


def write_map(path: Path, extra: str = "", time: str = "t", tunits: str = "ms",
              drive: str = "u_mV", vel: str = "velocity_mm_per_s", acc: str = "acc_g") -> Path:
    path.write_text(MAP_HEAD.format(time=time, tunits=tunits, drive=drive, vel=vel, acc=acc) + extra)
    return path


def lab_columns(scale: float = 1.0) -> dict[str, np.ndarray]:
    """The record as a lab exports it: time in ms, volts in mV, mm/s, g."""
    return {"t": T * 1e3, "u_mV": scale * VOLTS * 1e3, "velocity_mm_per_s": scale * VELOCITY * 1e3,
            "acc_g": scale * ACCEL / 9.80665}


def write_csv(path: Path, cols: dict[str, np.ndarray] | None = None, header: str = "") -> Path:
    cols = cols or lab_columns()
    names = list(cols)
    rows = np.column_stack([cols[n] for n in names])
    body = "\n".join(",".join(repr(float(v)) for v in row) for row in rows)
    path.write_text(header + ",".join(names) + "\n" + body + "\n")
    return path


def write_mat73(path: Path, tests: dict[str, dict[str, np.ndarray]]) -> Path:
    """A MATLAB v7.3 file (HDF5 with a 512-byte user block) holding one struct per test."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, cols in tests.items():
            g = f.create_group(name)
            g.attrs["MATLAB_class"] = np.bytes_(b"struct")
            for k, v in cols.items():
                ds = g.create_dataset(k, data=np.asarray(v, float).reshape(1, -1))  # column vector, transposed
                ds.attrs["MATLAB_class"] = np.bytes_(b"double")
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, written by the labjoint tests".ljust(116, b" "))
    return path
