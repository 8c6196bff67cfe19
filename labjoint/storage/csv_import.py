"""Import a CSV run (format in design.md) into a run file of the standard layout.

Imported runs carry physical values, not volts: each column is stored as-is in its
raw dataset with ``@units`` = its physical unit, sensor kind "imported" and a unity
calibration (sensitivity 1.0, range inf), so the reader's physical units are the
CSV's numbers exactly. Channels: ``displacement`` (m), ``force`` (N) and one per
extra column (named as in the header, quantity ``unknown``: a name is not a unit; a
channel map names quantities and units, :mod:`labjoint.storage.importers`). The file is
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
from labjoint.storage.csv_parse import ParsedCSV, parse_csv
from labjoint.storage.writer import utc_now

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
    md: dict[str, Any] = dict(parsed.metadata)
    md.update(displacement_channels=["displacement"], joint_force_channel="force")
    md.setdefault("csv_header", parsed.columns)
    return store_channels(parsed.path, parsed.column("time_s"), parsed.sample_rate_hz,
                          parsed.specs(), md, data_dir, name=name, catalog=catalog)


def safe_name(text: str) -> str:
    """A run name made of ``text`` (a file stem, an HDF5 group): other characters -> _."""
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", text).lstrip("._-") or "imported"


def store_channels(src: Path, time: np.ndarray, sample_rate_hz: float,
                   chans: list[tuple[ChannelSpec, np.ndarray]], metadata: dict[str, Any],
                   data_dir: str | Path, *, name: str | None = None, catalog: Any = None,
                   signal: str | None = None, extra: Any = None) -> Path:
    """Store channels in physical (SI) units as ``<data_dir>/<name>.h5`` (name: the
    source's stem): written under a temporary name, renamed only when complete.

    ``metadata`` may list ``drive_channels`` and ``response_channels``; every channel's
    quantity and unit come from its spec (:func:`layout.create_layout`); ``extra(f)``
    may write more (a processed group) into the open file before it is published.
    """
    name = safe_name(Path(src).stem) if name is None else name
    final = layout.run_path(data_dir, name)
    if catalog is not None:
        catalog.check_free(name, final)
    if final.exists():
        raise InputError("a run file with this name already exists; pass another name",
                         file=str(final))
    md = dict(metadata)
    now = utc_now()
    md.setdefault("start_time", now)
    md.update(plan=md.get("plan", "import"), source_file=str(Path(src).resolve()),
              imported_at=now)
    names = [c.name for c, _ in chans]
    Path(data_dir).mkdir(parents=True, exist_ok=True)
    tmp = layout.temp_path(final, f"{os.getpid()}-{secrets.token_hex(4)}")
    try:
        with layout.H5_LOCK, h5py.File(tmp, "w", libver="latest") as f:
            layout.create_layout(f, name=name, uid=secrets.token_hex(16),
                                 channels=[c for c, _ in chans], sample_rate_hz=sample_rate_hz,
                                 metadata=md, source="imported",
                                 signal=signal or ("force" if "force" in names else None),
                                 data_units=None)
            data = f["entry/data"]
            n = len(time)
            for key, values in [("time", time)] + [(c.name, v) for c, v in chans]:
                data[key].resize((n,))
                data[key][:] = values
            e = f["entry"]
            e["end_time"][()] = np.bytes_(now.encode())
            e["n_samples"][()] = n
            e["status"][()] = np.bytes_(b"complete")
            if extra is not None:
                extra(f)
        layout.publish(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    if catalog is not None:
        catalog.add(final)
    return final
