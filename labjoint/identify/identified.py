"""Identified values (mu, K_t, ...) with their uncertainty and provenance, and the
store that keeps their history in ``<data_dir>/identified.json``."""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from labjoint.errors import InputError

__all__ = ["IDENTIFIED_STORE", "Identified", "load_identified", "save_identified"]


@dataclass(frozen=True)
class Identified:
    """An identified quantity with its standard uncertainty and provenance."""

    name: str
    value: float
    uncertainty: float
    unit: str
    source: str
    method: str
    n_cycles: int = 0
    details: dict[str, Any] = field(default_factory=dict)

    @property
    def relative_uncertainty(self) -> float:
        return abs(self.uncertainty / self.value) if self.value else float("inf")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Identified":
        keys = {"name", "value", "uncertainty", "unit", "source", "method", "n_cycles", "details"}
        missing = {"name", "value", "uncertainty", "unit", "source", "method"} - set(d)
        if missing:
            raise InputError(f"identified value lacks {sorted(missing)}", field="identified")
        return cls(**{k: v for k, v in d.items() if k in keys})


IDENTIFIED_STORE = "identified.json"


def _store_path(data_dir: str | Path) -> Path:
    p = Path(data_dir)
    return p if p.suffix == ".json" else p / IDENTIFIED_STORE


def load_identified(data_dir: str | Path, name: str) -> Identified | None:
    """The latest stored value called ``name`` (e.g. "friction_coefficient"), or None."""
    p = _store_path(data_dir)
    if not p.exists():
        return None
    try:
        values = json.loads(p.read_text())["values"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(f"unreadable identified-values store: {exc}", file=str(p)) from None
    hist = values.get(name) or []
    return Identified.from_dict(hist[-1]) if hist else None


def save_identified(data_dir: str | Path, value: Identified) -> Path:
    """Append ``value`` to its history in ``<data_dir>/identified.json`` (atomic rewrite)."""
    p = _store_path(data_dir)
    data: dict[str, Any] = {"version": 1, "values": {}}
    if p.exists():
        try:
            data = json.loads(p.read_text())
            data.setdefault("values", {})
        except (OSError, ValueError) as exc:
            raise InputError(f"unreadable identified-values store: {exc}", file=str(p)) from None
    data["values"].setdefault(value.name, []).append(
        {**value.to_dict(), "stored": datetime.now(timezone.utc).isoformat(timespec="seconds")})
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", dir=p.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            json.dump(data, fh, indent=1, default=float)
        os.replace(tmp, p)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return p
