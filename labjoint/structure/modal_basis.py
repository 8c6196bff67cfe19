"""The measured linear modes a modal model is built on (:mod:`labjoint.structure.nlmode`,
issue 29 item 5): natural frequency, damping ratio and shape per mode, read from the JSON
of ``labjoint modes --json``; a shape measured complex keeps how far it is from real (the
model then adds quadrature participations, nlmode eq. 3b; :mod:`labjoint.compare.flags`
says so)."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.errors import InputError


@dataclass(frozen=True)
class MeasuredMode:
    frequency_hz: float
    damping_ratio: float
    shape: dict[str, float]
    #: how far the measured (complex) shape is from a real one: the largest phase from 0 or
    #: 180 deg over the sensors at >= 10 % of the mode's largest amplitude, and that sensor
    #: (0 and "" for a shape given real); ``shape`` holds the real parts
    phase_deg: float = 0.0
    phase_sensor: str = ""
    #: the shape's imaginary parts (sensors given [re, im]; empty for a shape given real):
    #: the two-point form reads them on each mode's quadrature (nlmode_pair eq. 7b)
    shape_im: Mapping[str, float] = field(default_factory=dict)


#: a measured mode further than this from real (deg, at a sensor of >= 10 % of its largest
#: amplitude) is complex: the modal model then gives every mode a quadrature participation
#: per sensor (nlmode eq. 3b, :func:`labjoint.structure.nlmode.lead`) and the fit says why (flags)
COMPLEX_DEG = 10.0


@dataclass(frozen=True)
class ModalBasis:
    """The measured linear modes (the first carries the joint) and the reference sensor."""

    modes: tuple[MeasuredMode, ...]
    reference: str
    source: str = ""

    @property
    def linear(self) -> tuple[MeasuredMode, ...]:
        return self.modes[1:]

    @property
    def complex(self) -> bool:
        """Some measured mode is further than COMPLEX_DEG from real."""
        return any(m.phase_deg > COMPLEX_DEG for m in self.modes)

    def to_dict(self) -> dict[str, Any]:
        """The basis as saved with a model: shapes as [re, im] where measured complex."""
        def shape(m: MeasuredMode) -> dict[str, Any]:
            if not any(m.shape_im.values()):
                return dict(m.shape)
            return {k: [v, float(m.shape_im.get(k, 0.0))] for k, v in m.shape.items()}

        return {"reference": self.reference, "source": self.source,
                "modes": [{"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio,
                           "shape": shape(m)} for m in self.modes]}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], source: str = "") -> ModalBasis:
        def part(v: Any, i: int) -> float:
            if isinstance(v, (list, tuple)):
                return float(v[i]) if len(v) > i else 0.0
            return float(v) if i == 0 else 0.0

        modes = []
        for m in d["modes"]:
            sh = m.get("shape") or {}
            z = {k: (part(v, 0), part(v, 1)) for k, v in sh.items()}
            modes.append(MeasuredMode(float(m["frequency_hz"]), float(m["damping_ratio"]),
                                      {k: a for k, (a, _) in z.items()}, *_complexity(sh),
                                      shape_im={k: b for k, (_, b) in z.items() if b}))
        return cls(tuple(modes), str(d["reference"]), source or str(d.get("source", "")))


def _complexity(shape: Mapping[str, Any]) -> tuple[float, str]:
    """(phase from real, deg; its sensor) of a shape of [re, im] pairs (MeasuredMode)."""
    z = {k: complex(float(v[0]), float(v[1])) for k, v in shape.items()
         if isinstance(v, (list, tuple)) and len(v) == 2}
    top = max((abs(c) for c in z.values()), default=0.0)
    out = (0.0, "")
    for k, c in z.items():
        if top > 0 and abs(c) >= 0.1 * top:
            a = abs(np.degrees(np.angle(c)))
            a = min(a, 180.0 - a)
            if a > out[0]:
                out = (float(a), k)
    return out


def load_basis(path: str | Path, reference: str | None = None) -> ModalBasis:
    """The modes of ``labjoint modes --json`` saved to a file (its first level: the
    lowest-level test), mode 1 the lowest in the file; ``reference``: the sensor whose
    mode-1 participation is 1 (default: the mode's own reference sensor)."""
    p = Path(path)
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read the modes file: {exc}", file=str(p), field="modal") from None
    return basis_from_json(d, str(p), reference)


def basis_from_json(d: Any, source: str = "", reference: str | None = None) -> ModalBasis:
    """The modes of ``labjoint modes --json`` (or a saved basis: ``reference`` and ``modes``)
    as a :class:`ModalBasis` (:func:`load_basis`; ``source`` names where they came from)."""
    p = source
    try:
        basis = _basis_from_json(d, p, reference)
    except InputError:
        raise
    except (KeyError, TypeError, ValueError, AttributeError, IndexError, ArithmeticError) as exc:
        raise InputError(f"not a modes file ({type(exc).__name__}: {exc}): expected the JSON of "
                         "`labjoint modes --json`", file=p or None, field="modal") from None
    for m in basis.modes:
        if not (np.isfinite(m.frequency_hz) and m.frequency_hz > 0 and np.isfinite(m.damping_ratio)
                and m.damping_ratio > 0 and all(np.isfinite(v) for v in m.shape.values())
                and all(np.isfinite(v) for v in m.shape_im.values())):
            raise InputError(f"mode at {m.frequency_hz} Hz (damping {m.damping_ratio}): a modal model "
                             "needs positive finite frequencies and damping and finite shapes",
                             file=p or None, field="modal")
        if m.shape.get(basis.reference, 1.0) == 0:
            raise InputError(f"mode at {m.frequency_hz} Hz does not move the reference sensor "
                             f"{basis.reference!r}: shapes are relative to it", file=p or None, field="modal")
    if not basis.modes:
        raise InputError("no modes", file=p or None, field="modal")
    return basis


def _basis_from_json(d: Any, p: str, reference: str | None) -> ModalBasis:
    if not isinstance(d, dict):
        raise InputError("not a modes file: expected a JSON object", file=p or None, field="modal")
    if "modes" in d and "reference" in d:
        basis = ModalBasis.from_dict(d, str(p))
    else:
        levels = d.get("levels") if isinstance(d, dict) else None
        if not levels or not levels[0].get("modes"):
            raise InputError("not a modes file: expected the JSON of `labjoint modes --json` "
                             "(levels[0].modes)", file=str(p), field="modal")
        lv = min(levels, key=lambda x: float(x.get("level") or 0.0))
        ms = sorted(lv["modes"], key=lambda m: m["frequency_hz"])
        for m in ms:
            if not (m["frequency_hz"] > 0 and m["damping_ratio"] > 0):
                raise InputError(f"mode at {m['frequency_hz']} Hz has damping {m['damping_ratio']}: "
                                 "a modal model needs positive frequencies and damping",
                                 file=str(p), field="modal")
        ref = ms[0].get("reference_sensor") or next(iter(ms[0]["shape"]))
        basis = ModalBasis.from_dict({"reference": ref, "modes": ms}, str(p))
    if reference is not None:
        if reference not in basis.modes[0].shape:
            raise InputError(f"no sensor {reference!r} in the modes; sensors: "
                             f"{sorted(basis.modes[0].shape)}", file=str(p), field="reference")
        basis = ModalBasis(basis.modes, reference, basis.source)
    return basis
