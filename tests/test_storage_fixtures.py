"""Shared helpers for the storage tests: the rig's channels and runs written from documents."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from labjoint.documents import Block, RunStart, RunStop
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage.writer import RunWriter

FS = 50_000.0
LSB = 10.0 / 2**24  # 24-bit converter over +-5 V (NI 9233)
NC_CAL = ((200.0, 280.0), (400.0, 301.0), (800.0, 320.0))  # nanocomposite N/V vs Hz


def rig_channels() -> list[ChannelSpec]:
    """The four channels of the seed-002 rig (sensitivities as in configs/rig-sim.toml)."""
    return [
        ChannelSpec("force_ref", "force", "force", "N", 50.0, iepe=True, physical_channel="ai0"),
        ChannelSpec("disp_1", "capacitive", "displacement", "m", 1.25e-5, physical_channel="ai1"),
        ChannelSpec("disp_2", "capacitive", "displacement", "m", 1.25e-5, physical_channel="ai2"),
        ChannelSpec("shear_nc", "nanocomposite", "force", "N", 301.0, physical_channel="ai3",
                    calibration=NC_CAL),
    ]


def quantise(volts: np.ndarray) -> np.ndarray:
    """Volts as a 24-bit converter delivers them."""
    return np.round(volts / LSB) * LSB


def write_run(data_dir: Path, name: str, volts: np.ndarray, *, block: int = 5000,
              metadata: dict | None = None, status: str = "complete", catalog=None,
              uid: str | None = None) -> Path:
    """Write ``volts`` (4, n) as one run through RunWriter, in blocks of ``block``."""
    uid = uid or f"uid-{name}"
    md = {"frequency_hz": 400.0, "excitation_vpp": 5.0, "torque_nm": 5.0,
          "normal_force_n": 2390.0, "plan": "amplitude_sweep", "plan_step": 0}
    md.update(metadata or {})
    w = RunWriter(data_dir, catalog=catalog)
    w("start", RunStart(uid, name, rig_channels(), FS, md))
    for a in range(0, volts.shape[1], block):
        w("block", Block(uid, a, volts[:, a:a + block]))
    w("stop", RunStop(uid, status, n_samples=volts.shape[1]))
    return data_dir / f"{name}.h5"


def walk_nexus(path: Path) -> list[str]:
    """Every NeXus rule the file breaks: @NX_class on groups, @units on datasets, NXdata."""
    problems: list[str] = []
    with h5py.File(path, "r") as f:
        if f.attrs.get("NX_class") != "NXroot":
            problems.append("/ lacks @NX_class=NXroot")

        def visit(name: str, obj) -> None:
            if isinstance(obj, h5py.Group):
                if "NX_class" not in obj.attrs:
                    problems.append(f"group {name} lacks @NX_class")
                elif obj.attrs["NX_class"] == "NXdata":
                    sig, axes = obj.attrs.get("signal"), obj.attrs.get("axes")
                    if sig not in obj or axes not in obj:
                        problems.append(f"{name}: @signal/@axes point nowhere")
                    elif obj[sig].shape != obj[axes].shape:
                        problems.append(f"{name}: signal and axis lengths differ")
            elif "units" not in obj.attrs:
                problems.append(f"dataset {name} lacks @units")

        f.visititems(visit)
    return problems
