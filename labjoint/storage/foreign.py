"""Records from other tools: LabVIEW TDMS files and HDF5 layouts (the Bouc-Wen
benchmark's), read through a small TOML channel map into the CSV import's columns.

A map names, for each column of the import format (design.md: ``displacement_m`` and
``force_N`` required, further columns ``name_unit``), where its samples are and the
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
from labjoint.storage.csv_parse import KNOWN_KEYS, REQUIRED, ParsedCSV, unit_of
from labjoint.storage.h5open import H5_FILE_ERRORS

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


def _tdms(path: Path, m: dict[str, Any]) -> tuple[dict[str, np.ndarray], float | None]:
    from nptdms import TdmsFile

    try:
        f = TdmsFile.read(path)
    except Exception as exc:  # nptdms raises ValueError, KeyError, struct errors ...
        raise InputError(f"not a readable TDMS file: {exc}", file=str(path)) from None
    out, fs = {}, None
    for col, c in m["channels"].items():
        g, ch = c.get("group"), c.get("channel")
        try:
            obj = f[str(g)][str(ch)]
        except KeyError:
            have = {gr.name: [x.name for x in gr.channels()] for gr in f.groups()}
            raise InputError(f"no channel {ch!r} in group {g!r}; the file has {have}",
                             file=str(path), field=col) from None
        out[col] = np.asarray(obj[:], dtype=float) * float(c.get("scale", 1.0))
        inc = obj.properties.get("wf_increment")
        if fs is None and inc:
            fs = 1.0 / float(inc)
    return out, fs


#: Values of one dataset an import reads (1000 s at 50 kS/s; 400 MB as float64).
MAX_IMPORT_SAMPLES = 50_000_000


def _hdf5(path: Path, m: dict[str, Any]) -> tuple[dict[str, np.ndarray], float | None]:
    import h5py

    try:
        f = h5py.File(path, "r")
    except H5_FILE_ERRORS as exc:
        raise InputError(f"not a readable HDF5 file: {exc}", file=str(path)) from None
    with f:
        def get(name: str, field: str) -> np.ndarray:
            if name not in f or not isinstance(f[name], h5py.Dataset):
                raise InputError(f"no dataset {name!r}", file=str(path), field=field)
            ds = f[name]                   # checked as declared, before it is read
            if ds.dtype.kind not in "biuf":
                raise InputError(f"dataset {name!r} holds {ds.dtype} values, not real numbers "
                                 "(a complex channel is refused, not truncated)",
                                 file=str(path), field=field)
            if ds.size > MAX_IMPORT_SAMPLES:
                raise InputError(f"dataset {name!r} declares {ds.size:.3g} values; at most "
                                 f"{MAX_IMPORT_SAMPLES:.3g} are imported", file=str(path),
                                 field=field)
            try:
                return np.asarray(ds[()], dtype=float)
            except H5_FILE_ERRORS as exc:
                raise InputError(f"cannot read dataset {name!r}: {exc}", file=str(path),
                                 field=field) from None
        out = {}
        for col, c in m["channels"].items():
            a = get(str(c.get("dataset")), col)
            if a.ndim == 2 and ("column" in c or a.shape[1] == 1):
                k = int(c.get("column", 0))
                if not 0 <= k < a.shape[1]:
                    raise InputError(f"column {k} outside the dataset's {a.shape[1]}",
                                     file=str(path), field=col)
                a = a[:, k]
            if a.ndim != 1:
                raise InputError(f"dataset of shape {a.shape}: give column = k", file=str(path),
                                 field=col)
            out[col] = a * float(c.get("scale", 1.0))
        fs = None
        if "sample_rate_dataset" in m:
            fs = float(np.ravel(get(str(m["sample_rate_dataset"]), "sample_rate_dataset"))[0])
    return out, fs


def read_foreign(path: str | Path, channel_map: str | Path | dict[str, Any]) -> ParsedCSV:
    """The record at ``path`` as the CSV import's columns (module docstring)."""
    p = Path(path)
    m = load_map(channel_map)
    if not p.is_file():
        raise InputError("no such file", file=str(p))
    fmt = _fmt(p, m)
    cols, fs_file = (_tdms if fmt == "tdms" else _hdf5)(p, m)
    fs = m.get("sample_rate_hz", fs_file)
    if fs is None:
        raise InputError("no sample rate: give sample_rate_hz in the map", file=str(p),
                         field="sample_rate_hz")
    if isinstance(fs, bool) or not isinstance(fs, (int, float)) or not (math.isfinite(fs) and fs > 0):
        raise InputError(f"sample rate must be > 0, got {fs!r}", file=str(p), field="sample_rate_hz")
    lengths = {c: a.size for c, a in cols.items()}
    if len(set(lengths.values())) != 1:
        raise InputError(f"channels of unequal length {lengths}: refused, not truncated",
                         file=str(p), field="channels")
    n = next(iter(lengths.values()))
    if n < 2:
        raise InputError("need at least 2 samples", file=str(p), field="channels")
    for c, a in cols.items():
        if not np.all(np.isfinite(a)):
            k = int(np.flatnonzero(~np.isfinite(a))[0])
            raise InputError(f"sample {k} is not a finite number", file=str(p), field=c)
    md = dict(m.get("metadata", {}))
    for k in KNOWN_KEYS:
        if k in md and (isinstance(md[k], bool) or not isinstance(md[k], (int, float))):
            raise InputError(f"{k} must be a number, got {md[k]!r}", file=str(p), field=k)
    md["sample_rate_hz"] = float(fs)
    drive = md.get("frequency_hz")
    if drive is not None and drive >= fs / 2:
        raise InputError(f"frequency_hz {drive:g} Hz is at or above the Nyquist frequency "
                         f"{fs / 2:g} Hz of the record", file=str(p), field="frequency_hz")
    md["source_format"] = fmt
    md["channel_map"] = m["_source"]
    names = ["time_s", "displacement_m", "force_N"] + [c for c in cols if c not in REQUIRED]
    t = np.arange(n) / float(fs)
    values = np.column_stack([t] + [cols[c] for c in names[1:]])
    return ParsedCSV(p, names, values, md, float(fs))
