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

A **backbone file** (JSON, ``format`` = ``labjoint.backbone/1``; :func:`save_backbones`,
:func:`load_backbones`) holds the backbones of one mode measured on one structure, one
per method: {"format", "mode" (1-based), "backbones": [Backbone.to_dict(), ...]}.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.errors import InputError

FORMAT = "labjoint.backbone/1"
#: the fields every point of a file carries (the rest are kept as ``extra``)
POINT_FIELDS = ("amplitude", "frequency_hz", "damping_ratio", "method", "amplitude_sd",
                "frequency_sd_hz", "damping_sd")


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

    def by_method(self) -> list[Backbone]:
        """One backbone per method of its points (in the order they first appear), each
        with this one's sensor, units and notes: a ringdown's Hilbert and peak estimates
        are two measurements of the backbone, never one merged curve.

        >>> b = Backbone([BackbonePoint(1e-6, 30.0, 0.01, "a"), BackbonePoint(2e-6, 29.9, 0.01, "b")],
        ...              "m", "displacement", "tip")
        >>> [len(x.points) for x in b.by_method()], [x.points[0].method for x in b.by_method()]
        ([1, 1], ['a', 'b'])
        """
        methods = dict.fromkeys(p.method for p in self.points)
        return [replace(self, points=[p for p in self.points if p.method == m]) for m in methods]

    def with_method(self, method: str) -> Backbone:
        return replace(self, points=[replace(p, method=method) for p in self.points])

    def to_dict(self) -> dict:
        return {"sensor": self.sensor, "quantity": self.quantity,
                "amplitude_units": self.amplitude_units, "notes": list(self.notes),
                "points": [p.to_dict(self.amplitude_units) for p in self.points]}


def _point(d: Any, where: str, file: str | None) -> BackbonePoint:
    if not isinstance(d, dict):
        raise InputError("a point must be an object", file=file, field=where)
    vals: dict[str, Any] = {}
    for k in POINT_FIELDS:
        v = d.get(k, 0.0 if k.endswith("_sd") else None)
        if k == "method":
            if not isinstance(v, str) or not v:
                raise InputError("missing or empty", file=file, field=f"{where}.method")
        elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"must be a finite number, got {v!r}", file=file, field=f"{where}.{k}")
        vals[k] = v
    for k in ("amplitude", "frequency_hz"):
        if not vals[k] > 0:
            raise InputError(f"must be > 0, got {vals[k]!r}", file=file, field=f"{where}.{k}")
    for k in POINT_FIELDS:
        if k.endswith("_sd") and vals[k] < 0:
            raise InputError(f"an uncertainty must be >= 0, got {vals[k]!r}", file=file, field=f"{where}.{k}")
    extra = {k: v for k, v in d.items() if k not in POINT_FIELDS and k != "amplitude_units"}
    return BackbonePoint(**vals, extra=extra)


def backbone_from_dict(d: Any, where: str = "backbone", file: str | None = None) -> Backbone:
    """Inverse of :meth:`Backbone.to_dict`; a bad field raises InputError naming it."""
    if not isinstance(d, dict):
        raise InputError("a backbone must be an object", file=file, field=where)
    pts = d.get("points")
    if not isinstance(pts, list):
        raise InputError("must be a list of points", file=file, field=f"{where}.points")
    for k in ("amplitude_units", "quantity", "sensor"):
        if not isinstance(d.get(k), str):
            raise InputError("missing (a string)", file=file, field=f"{where}.{k}")
    return Backbone([_point(p, f"{where}.points[{i}]", file) for i, p in enumerate(pts)],
                    d["amplitude_units"], d["quantity"], d["sensor"],
                    tuple(str(n) for n in d.get("notes") or ()))


def is_backbone_file(item: Any) -> bool:
    """A .json path whose head states the backbone format."""
    if not isinstance(item, (str, Path)) or Path(item).suffix.lower() != ".json":
        return False
    try:
        with open(item, encoding="utf-8") as fh:
            return FORMAT in fh.read(4096)
    except (OSError, UnicodeDecodeError):
        return False


def save_backbones(path: str | Path, backbones: list[Backbone], mode: int = 1) -> Path:
    """Write the backbones of mode ``mode`` (1-based) as a backbone file, in one step."""
    p = Path(path)
    d = {"format": FORMAT, "mode": int(mode), "backbones": [b.to_dict() for b in backbones]}
    tmp = p.with_name(f".{p.name}.tmp")
    tmp.write_text(json.dumps(d, allow_nan=False))
    os.replace(tmp, p)
    return p


def load_backbones(path: str | Path) -> tuple[list[Backbone], int]:
    """The backbones and the (1-based) mode of a backbone file; errors name the file and field."""
    p = Path(path)
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"not a readable backbone file ({exc})", file=str(p)) from None
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise InputError(f"not a backbone file (format must be {FORMAT!r})", file=str(p), field="format")
    mode = d.get("mode", 1)
    if isinstance(mode, bool) or not isinstance(mode, int) or mode < 1:
        raise InputError(f"must be a whole number >= 1, got {mode!r}", file=str(p), field="mode")
    bs = d.get("backbones")
    if not isinstance(bs, list) or not bs:
        raise InputError("must be a non-empty list", file=str(p), field="backbones")
    return [backbone_from_dict(b, f"backbones[{i}]", str(p)) for i, b in enumerate(bs)], mode
