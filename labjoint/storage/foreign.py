"""Records from other tools through the older, joint-level map form: LabVIEW TDMS files
and HDF5 layouts (the Bouc-Wen benchmark's) into the CSV import's columns. Such a map is
turned into a :class:`~labjoint.storage.channel_map.ChannelMap` (:func:`legacy_channel_map`)
and read and checked by the channel-map importer, like every other lab export; maps with
a quantity and unit per channel (:mod:`labjoint.storage.channel_map`) say more.

A map names, for each column of the import format (design.md: ``displacement_m`` and
``force_N`` required; further columns are kept with quantity ``unknown``: a name is not
a unit), where its samples are and the
factor that brings them to the column's SI unit; the sample rate comes from the map, a
dataset, or the TDMS channel's ``wf_increment``; ``[metadata]`` adds the CSV's
``# key: value`` metadata::

    format = "tdms"                          # or "hdf5" (default: from the suffix)
    sample_rate_hz = 51200.0                 # optional for TDMS (wf_increment)
    [channels.displacement_m]
    group = "Measurement"                    # TDMS group and channel
    channel = "Disp"
    scale = 1e-6                             # um -> m
    [channels.force_N]
    group = "Measurement"
    channel = "Force"
    [metadata]
    frequency_hz = 400.0

For HDF5, a column gives ``dataset = "group/name"`` (a 1-D dataset, or 2-D with one
column or a ``column = k``) and the sample rate ``sample_rate_dataset = "group/fs"``.
:data:`PRESETS` holds the Bouc-Wen benchmark's layout (``--map boucwen``). Channels of
unequal length, missing channels, non-finite samples and a drive frequency at or above
Nyquist are refused with an error naming the file and the channel.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.storage.channel_map import ChannelMap, MapChannel
from labjoint.storage.csv_parse import REQUIRED, ParsedCSV, unit_of

FOREIGN_SUFFIXES = {".tdms": "tdms", ".h5": "hdf5", ".hdf5": "hdf5"}
#: built-in maps, by name
PRESETS: dict[str, dict[str, Any]] = {
    "boucwen": {"format": "hdf5", "sample_rate_dataset": "multisine/fs",
                "channels": {"displacement_m": {"dataset": "multisine/y"},
                             "force_N": {"dataset": "multisine/u"}}},
}


def load_map(spec: str | Path | dict[str, Any]) -> dict[str, Any]:
    """A channel map from a TOML file, a preset name (:data:`PRESETS`) or a dict, checked."""
    if isinstance(spec, dict):
        m, src = spec, "inline map"
    elif str(spec) in PRESETS:
        m = PRESETS[str(spec)]
        src = f"preset {spec}"
    else:
        p = Path(spec)
        try:
            m = tomllib.loads(p.read_text())
        except OSError as exc:
            raise InputError(f"cannot read the channel map ({exc.strerror}); presets: "
                             f"{sorted(PRESETS)}", file=str(p)) from None
        except tomllib.TOMLDecodeError as exc:
            raise InputError(f"not valid TOML: {exc}", file=str(p)) from None
        src = str(p)
    chans = m.get("channels")
    if not isinstance(chans, dict):
        raise InputError("the map needs a [channels] table", file=src, field="channels")
    for need in REQUIRED[1:]:
        if need not in chans:
            raise InputError(f"the map has no [channels.{need}]", file=src, field="channels")
    for col, c in chans.items():
        if not isinstance(c, dict):
            raise InputError(f"[channels.{col}] must be a table", file=src, field=col)
        if not unit_of(col) or col.lower() == "time_s":
            raise InputError(f"column name {col!r} needs a unit suffix (name_unit)", file=src,
                             field=col)
        scale = c.get("scale", 1.0)
        if isinstance(scale, bool) or not isinstance(scale, (int, float)) \
                or not math.isfinite(scale) or scale == 0:
            raise InputError(f"scale must be a finite non-zero number, got {scale!r}", file=src,
                             field=f"{col}.scale")
    return {**m, "_source": src}


def _fmt(path: Path, m: dict[str, Any]) -> str:
    fmt = m.get("format") or FOREIGN_SUFFIXES.get(path.suffix.lower())
    if fmt not in ("tdms", "hdf5"):
        raise InputError(f"unknown file format {fmt or path.suffix!r}: give format = 'tdms' or "
                         "'hdf5' in the map", file=str(path), field="format")
    return fmt


def legacy_channel_map(m: dict[str, Any], fmt: str) -> ChannelMap:
    """An older-form map (checked by :func:`load_map`) as a :class:`ChannelMap`:
    ``displacement_m`` -> channel ``displacement`` (m, a response), ``force_N`` ->
    ``force`` (N, the drive), further columns kept with quantity ``unknown``."""
    known = {"displacement_m": ("displacement", "displacement", "m", "response"),
             "force_n": ("force", "force", "N", "drive")}
    channels = []
    for col, c in m["channels"].items():
        name, quantity, units, role = known.get(col.lower(), (col, "unknown", "", "other"))
        source = f"{c.get('group')}/{c.get('channel')}" if fmt == "tdms" else str(c.get("dataset"))
        column = int(c["column"]) if "column" in c else None
        channels.append(MapChannel(name, source, quantity, units, units, float(c.get("scale", 1.0)),
                                   role, column))
    time: dict[str, Any] = {}
    if "sample_rate_hz" in m:
        time["sample_rate_hz"] = m["sample_rate_hz"]
    elif "sample_rate_dataset" in m:
        time["sample_rate_source"] = str(m["sample_rate_dataset"])
    return ChannelMap(m["_source"], fmt, channels, time=time, metadata=dict(m.get("metadata", {})))


def read_foreign(path: str | Path, channel_map: str | Path | dict[str, Any]) -> ParsedCSV:
    """The record at ``path`` as the CSV import's columns (module docstring), read and
    checked by the channel-map importer (:mod:`labjoint.storage.importers`)."""
    from labjoint.storage.importers import prepare_record
    from labjoint.storage.sources import read_tests

    p = Path(path)
    m = load_map(channel_map)
    if not p.is_file():
        raise InputError("no such file", file=str(p))
    fmt = _fmt(p, m)
    cmap = legacy_channel_map(m, fmt)
    if "sample_rate_hz" in m:
        fs = m["sample_rate_hz"]
        if isinstance(fs, bool) or not isinstance(fs, (int, float)) or not (math.isfinite(fs) and fs > 0):
            raise InputError(f"sample rate must be > 0, got {fs!r}", file=str(p),
                             field="sample_rate_hz")
    pr = prepare_record(read_tests(p, fmt, [], {})[0], cmap)
    cols = {spec.name: x for spec, x in pr.channels}
    names = ["time_s", "displacement_m", "force_N"] + [c for c in cols if c not in ("displacement", "force")]
    values = np.column_stack([pr.time, cols["displacement"], cols["force"]] +
                             [cols[c] for c in names[3:]])
    md = {k: v for k, v in pr.metadata.items()
          if k not in ("drive_channels", "response_channels", "source_units", "source_test")}
    md.update(sample_rate_hz=pr.sample_rate_hz, source_format=fmt, channel_map=m["_source"])
    return ParsedCSV(p, names, values, md, pr.sample_rate_hz)
