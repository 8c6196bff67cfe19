"""Backbone points: natural frequency and damping ratio of one mode at one vibration
amplitude, with their standard uncertainties and the method that gave them.

Every producer (ringdowns, :mod:`labjoint.signal.ringdown`; phase resonance and step
sine, :mod:`labjoint.identify.backbone`; models, :mod:`labjoint.identify.backbone_sdof`
and :mod:`labjoint.structure.epmc`) returns a :class:`Backbone`, so the CLI, the
comparison kind and the plots read one shape. SI inside: the amplitude is in
``amplitude_units`` of ``quantity`` at ``sensor`` (or a modal amplitude), frequency in
Hz, damping ratio dimensionless. An uncertainty of 0 means "not estimated" only for
model curves (they carry none); measured points always carry one.

>>> b = Backbone([BackbonePoint(1e-6, 30.0, 0.01, "hilbert")], "m", "displacement", "tip")
>>> b.to_dict()["points"][0]["frequency_hz"]
30.0
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np


@dataclass(frozen=True)
class BackbonePoint:
    """One point of a backbone (module docstring); ``*_sd`` are standard uncertainties."""

    amplitude: float
    frequency_hz: float
    damping_ratio: float
    method: str
    amplitude_sd: float = 0.0
    frequency_sd_hz: float = 0.0
    damping_sd: float = 0.0
    extra: dict = field(default_factory=dict, compare=False)

    def to_dict(self, units: str) -> dict:
        d = {"amplitude": float(self.amplitude), "amplitude_units": units,
             "frequency_hz": float(self.frequency_hz), "damping_ratio": float(self.damping_ratio),
             "method": self.method, "amplitude_sd": float(self.amplitude_sd),
             "frequency_sd_hz": float(self.frequency_sd_hz), "damping_sd": float(self.damping_sd)}
        d.update(self.extra)
        return d


@dataclass(frozen=True)
class Backbone:
    """Points of one mode's backbone, amplitude ascending."""

    points: list[BackbonePoint]
    amplitude_units: str
    quantity: str
    sensor: str
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "points", sorted(self.points, key=lambda p: p.amplitude))

    def array(self, name: str) -> np.ndarray:
        """One field of every point as an array (e.g. ``"frequency_hz"``)."""
        return np.array([getattr(p, name) for p in self.points], float)

    def with_method(self, method: str) -> Backbone:
        return replace(self, points=[replace(p, method=method) for p in self.points])

    def to_dict(self) -> dict:
        return {"sensor": self.sensor, "quantity": self.quantity,
                "amplitude_units": self.amplitude_units, "notes": list(self.notes),
                "points": [p.to_dict(self.amplitude_units) for p in self.points]}
