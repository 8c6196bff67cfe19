"""Import a CSV run (format in design.md) into a run file of the standard layout.

Imported runs carry physical values, not volts: each column is stored as-is in its
raw dataset with ``@units`` = its physical unit, sensor kind "imported" and a unity
calibration (sensitivity 1.0, range inf), so the reader's physical units are the
CSV's numbers exactly. Channels: ``displacement`` (m), ``force`` (N) and one per
extra column (named as in the header, unit from the name's suffix). The file is
written under a temporary name and renamed only when complete; a failed import
leaves nothing in ``data_dir``.

>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "r1.csv").write_text("# frequency_hz: 400\\ntime_s,displacement_m,force_N\\n"
...                               "0,0,0\\n0.001,1e-6,2.5\\n0.002,2e-6,5\\n")
>>> from labjoint.storage.reader import read_run
>>> run = read_run(import_csv(d / "r1.csv", d / "data"))
>>> run.force.tolist(), run.sample_rate_hz
([0.0, 2.5, 5.0], 1000.0)
"""

from __future__ import annotations

import math
import os
import re
import secrets
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from labjoint.errors import InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage import layout
from labjoint.storage.csv_parse import ParsedCSV, parse_csv, unit_of
from labjoint.storage.writer import utc_now

_QUANTITY_BY_UNIT = {"N": "force", "m": "displacement", "s": "time", "V": "voltage"}


def _channels(parsed: ParsedCSV) -> list[tuple[ChannelSpec, np.ndarray]]:
    out = []
    required = {"displacement_m": ("displacement", "displacement", "m"),
                "force_n": ("force", "force", "N")}
    for key, (name, quantity, unit) in required.items():
        spec = ChannelSpec(name=name, sensor="imported", quantity=quantity, unit=unit,
                           sensitivity=1.0, range_v=math.inf, coupling="DC")
        out.append((spec, parsed.column(key)))
    for col in parsed.columns:
        if col.lower() in ("time_s", "displacement_m", "force_n"):
            continue
        unit = unit_of(col)
        spec = ChannelSpec(name=col, sensor="imported",
                           quantity=_QUANTITY_BY_UNIT.get(unit, "voltage"), unit=unit,
                           sensitivity=1.0, range_v=math.inf, coupling="DC")
        out.append((spec, parsed.column(col)))
    return out


def import_csv(csv_path: str | Path, data_dir: str | Path, name: str | None = None,
               catalog: Any = None) -> Path:
    """Validate ``csv_path`` and store it as ``<data_dir>/<name>.h5`` (name: the CSV stem).

    Raises InputError (naming file, line and column) for bad input, or if a run of
    that name exists; nothing is left behind on failure.
    """
    return import_parsed(parse_csv(csv_path), data_dir, name, catalog)


def import_parsed(parsed: ParsedCSV, data_dir: str | Path, name: str | None = None,
                  catalog: Any = None) -> Path:
    """Store columns read by :func:`parse_csv` or :func:`labjoint.storage.foreign.read_foreign`
    as ``<data_dir>/<name>.h5`` (name: the source file's stem)."""
    src = parsed.path
    if name is None:
        name = re.sub(r"[^A-Za-z0-9_.\-]", "_", src.stem).lstrip("._-") or "imported"
    final = layout.run_path(data_dir, name)
    if catalog is not None:
        catalog.check_free(name, final)
    if final.exists():
        raise InputError("a run file with this name already exists; pass another name",
                         file=str(final))
    chans = _channels(parsed)
    md: dict[str, Any] = dict(parsed.metadata)
    now = utc_now()
    md.setdefault("start_time", now)
    md.update(plan=md.get("plan", "import"), source_file=str(src.resolve()), imported_at=now,
              displacement_channels=["displacement"], joint_force_channel="force")
    md.setdefault("csv_header", parsed.columns)
    Path(data_dir).mkdir(parents=True, exist_ok=True)
    tmp = layout.temp_path(final, f"{os.getpid()}-{secrets.token_hex(4)}")
    try:
        with layout.H5_LOCK, h5py.File(tmp, "w", libver="latest") as f:
            layout.create_layout(f, name=name, uid=secrets.token_hex(16),
                                 channels=[c for c, _ in chans],
                                 sample_rate_hz=parsed.sample_rate_hz, metadata=md,
                                 source="imported", signal="force", data_units=None)
            data = f["entry/data"]
            n = parsed.values.shape[0]
            for key, values in [("time", parsed.column("time_s"))] + [(c.name, v) for c, v in chans]:
                data[key].resize((n,))
                data[key][:] = values
            e = f["entry"]
            e["end_time"][()] = np.bytes_(now.encode())
            e["n_samples"][()] = n
            e["status"][()] = np.bytes_(b"complete")
        layout.publish(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    if catalog is not None:
        catalog.add(final)
    return final
