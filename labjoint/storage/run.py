"""A run in physical units, as every layer above storage sees it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from labjoint.storage.roles import channel_roles


@dataclass
class Run:
    """One run: time (s), relative displacement (m) and joint force (N), SI units.

    ``channels`` holds every channel in physical units (name -> array);
    ``metadata`` holds frequency_hz, sample_rate_hz, torque_nm, excitation_vpp,
    normal_force_n and whatever else the file carried.
    """

    name: str
    time: np.ndarray
    displacement: np.ndarray
    force: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)
    channels: dict[str, np.ndarray] = field(default_factory=dict)
    path: str | None = None

    @property
    def sample_rate_hz(self) -> float:
        fs = self.metadata.get("sample_rate_hz")
        if fs:
            return float(fs)
        return float(1.0 / np.median(np.diff(self.time)))

    @property
    def frequency_hz(self) -> float | None:
        f = self.metadata.get("frequency_hz")
        return None if f is None else float(f)

    @property
    def excitation(self) -> np.ndarray:
        """The signal that tells what excites the run: the reference (drive) force if
        recorded, else the joint force (a joint's own force may fade, e.g. with wear,
        under a steady drive)."""
        ref = self.channels.get(channel_roles(self.metadata, self.channels).reference_force)
        return self.force if ref is None or len(ref) != len(self.force) else ref

    def __len__(self) -> int:
        return len(self.time)
