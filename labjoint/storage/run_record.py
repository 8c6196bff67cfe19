"""A catalog row: :class:`RunRecord`, made from an open run file or a ``runs`` table row."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from labjoint.errors import InputError
from labjoint.storage.reader import RunFile


@dataclass
class RunRecord:
    """One catalog row; ``metadata`` holds every other metadata key of the run."""

    name: str
    path: str
    uid: str = ""
    plan: str = ""
    plan_step: Any = None
    frequency_hz: float | None = None
    excitation_vpp: float | None = None
    torque_nm: float | None = None
    normal_force_n: float | None = None
    sample_rate_hz: float | None = None
    n_samples: int | None = None
    status: str = ""
    start_time: str = ""
    start_ts: float | None = None
    end_time: str = ""
    source: str = ""
    metadata: dict[str, Any] = field(default_factory=dict)


def _timestamp(value: Any, *, field: str = "start_time") -> float | None:
    """Seconds since the epoch of an ISO 8601 string, datetime or number (naive = UTC)."""
    if value is None or value == "":
        return None
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str):
        try:
            value = datetime.fromisoformat(value)
        except ValueError:
            raise InputError(f"not an ISO 8601 time: {value!r}", field=field) from None
    if isinstance(value, datetime):
        if value.tzinfo is None:
            value = value.replace(tzinfo=timezone.utc)
        return value.timestamp()
    raise InputError(f"not a time: {value!r}", field=field)


def _num(v: Any) -> float | None:
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def record_from_run(rf: RunFile) -> RunRecord:
    """The catalog record of an open run file."""
    md = dict(rf.metadata)
    rec = RunRecord(
        name=rf.name, path=str(Path(rf.path).resolve()), uid=rf.uid,
        plan=str(md.pop("plan", "") or ""), plan_step=md.pop("plan_step", None),
        frequency_hz=_num(md.pop("frequency_hz", None)),
        excitation_vpp=_num(md.pop("excitation_vpp", None)),
        torque_nm=_num(md.pop("torque_nm", None)),
        normal_force_n=_num(md.pop("normal_force_n", None)),
        sample_rate_hz=_num(md.pop("sample_rate_hz", None)),
        n_samples=rf.n_samples, status=rf.status,
        start_time=str(md.pop("start_time", "") or ""), end_time=rf.end_time,
        source=rf.source)
    for k in ("name", "uid", "status", "end_time", "n_samples", "source"):
        md.pop(k, None)
    try:
        rec.start_ts = _timestamp(rec.start_time)
    except InputError:
        rec.start_ts = None
    rec.metadata = md
    return rec


def record_from_row(row: dict[str, Any]) -> RunRecord:
    """The record of a ``SELECT * FROM runs`` row."""
    d = {k: v for k, v in row.items() if k != "extra"}
    d["metadata"] = json.loads(row["extra"]) if row["extra"] else {}
    return RunRecord(**d)
