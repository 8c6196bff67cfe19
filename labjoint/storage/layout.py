"""The NeXus-style layout of a run file, shared by the streaming writer and CSV import.

::

    /                       @NX_class=NXroot  @default=entry
    /entry                  NXentry: title, entry_identifier, start_time, end_time*,
                            status*, n_samples*, software_version, program_name, plan,
                            plan_step, metadata_json; typed @frequency_hz, @excitation_vpp,
                            @offset_v, @torque_nm, @normal_force_n, @sample_rate_hz
    /entry/sample           NXsample: bolt_torque (N*m), normal_force (N)
    /entry/instrument       NXinstrument: generator (NXcollection), daq (NXcollection),
                            one NXsensor per channel (type, measurement, unit,
                            sensitivity, range, coupling, calibration table)
    /entry/data             NXdata @signal @axes=time: one raw dataset per channel, time
    /entry/acquisition      NXcollection: gaps* (expected, got), events*, continuous*,
                            writer_pid, writer_host
    /entry/processed        NXcollection: one NXprocess per result, never over raw data

Starred datasets change while a run is written. SWMR writers may only write into or
extend datasets that already exist (no new objects or attributes), so everything that
changes is a pre-created fixed-size dataset (``status`` S16, ``end_time`` S40,
``n_samples``) or a resizable chunked one. Every dataset has ``@units`` ("" = none).
Every channel dataset also has ``@quantity`` (displacement, velocity, acceleration, force,
voltage, or another kept as given) and ``@physical_units``, the SI unit of that quantity
(:mod:`labjoint.storage.quantities`); ``@units`` is the unit of the stored numbers: "V"
for an acquired run's raw volts, the SI unit itself for an imported run. The metadata
lists ``channel_quantities``, ``drive_channels`` and ``response_channels``.

Raw channel data are float64 volts: the DAQ driver hands out float64 values already
scaled by its own calibration polynomial, and float64 keeps them bit-exact; float32
would re-round them by up to 0.4 LSB of a 24-bit +-5 V converter near full scale.
The ``time`` axis is written from the DAQ sample counter (first_sample / fs), so a
gap shows in it; stored gzip+shuffle it costs about 4 % of one raw channel.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
import re
import threading
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from labjoint import __version__
from labjoint.errors import InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage.roles import channel_roles

#: Every HDF5 access of this process goes through this lock: reader and writer calls,
#: and multi-step sequences (refresh, then shape, then slice) are atomic with respect to
#: each other. h5py alone does not make concurrent reads of one file safe (16 threads
#: reading windows of a run got each other's samples, compressed time axis included).
H5_LOCK = threading.RLock()


def locked(fn: Any) -> Any:
    """Run ``fn`` holding :data:`H5_LOCK`."""
    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with H5_LOCK:
            return fn(*args, **kwargs)
    return wrapper


FORMAT_VERSION = 1
STATUS_DTYPE = "S16"
TIME_DTYPE = "S40"
CHUNK_SAMPLES = 32768
EVENT_TEXT_BYTES = 1024
EVENT_DTYPE = np.dtype([("kind", "S16"), ("name", "S64"), ("sample", "<i8"),
                        ("part", "<i4"), ("nparts", "<i4"), ("text", f"S{EVENT_TEXT_BYTES}")])
#: Metadata keys stored as typed attributes on /entry (and as catalog columns).
KNOWN_KEYS = ("frequency_hz", "excitation_vpp", "offset_v", "torque_nm",
              "normal_force_n", "sample_rate_hz")
_UNIT_SUFFIX = {"hz": "Hz", "vpp": "V", "v": "V", "nm": "N*m", "n": "N", "m": "m",
                "s": "s", "j": "J", "pa": "Pa", "ms": "ms"}
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]{0,199}$")


def check_run_name(name: str, *, field: str = "name") -> str:
    """A run name usable as a file name: letters, digits, ``_ . -``, at most 200."""
    if not isinstance(name, str) or not _NAME_RE.match(name) or name.endswith(".h5"):
        raise InputError(f"run name {name!r} must be 1-200 of [A-Za-z0-9_.-], "
                         "start with a letter or digit, without '.h5'", field=field)
    return name


def run_path(data_dir: str | Path, name: str) -> Path:
    """Where the run called ``name`` lives in ``data_dir``."""
    return Path(data_dir) / f"{check_run_name(name)}.h5"


def temp_path(final: Path, token: str) -> Path:
    """A hidden temporary name beside ``final`` (never matches ``*.h5``)."""
    return final.with_name(f".{final.name}.tmp-{token}")


def publish(tmp: Path, final: Path) -> None:
    """Give the finished file ``tmp`` the name ``final`` atomically; never overwrite.

    The data are fsynced first, so after a crash ``final`` is either absent or whole.
    """
    with open(tmp, "rb") as fh:
        os.fsync(fh.fileno())
    try:
        os.link(tmp, final)
    except FileExistsError:
        raise InputError("a run file with this name already exists", file=str(final)) from None
    except OSError:  # no hard links on this filesystem: check, then rename
        if final.exists():
            raise InputError("a run file with this name already exists", file=str(final)) from None
        os.replace(tmp, final)
    else:
        tmp.unlink()
    try:
        dfd = os.open(final.parent, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dfd)
    except OSError:
        pass
    finally:
        os.close(dfd)


def unit_for_key(key: str) -> str:
    """Unit implied by a metadata key's suffix (``frequency_hz`` -> Hz), else ""."""
    suffix = key.rsplit("_", 1)[-1].lower() if "_" in key else ""
    return _UNIT_SUFFIX.get(suffix, "")


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return dataclasses.asdict(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON-serialisable")


def to_json(value: Any, *, field: str = "metadata") -> str:
    """JSON text of ``value`` (numpy scalars, arrays, dataclasses allowed)."""
    try:
        return json.dumps(value, default=_json_default, allow_nan=True, sort_keys=True)
    except (TypeError, ValueError) as exc:
        raise InputError(f"not JSON-serialisable: {exc}", field=field) from None


def text(group: h5py.Group, name: str, value: str, *, fixed: str | None = None) -> h5py.Dataset:
    """A scalar text dataset with ``@units=""``; ``fixed`` gives a fixed byte size."""
    if fixed is None:
        ds = group.create_dataset(name, data=value, dtype=h5py.string_dtype())
    else:
        size = int(fixed[1:])
        raw = value.encode()
        if len(raw) > size:
            raise InputError(f"{len(raw)} bytes, at most {size}", field=name)
        ds = group.create_dataset(name, data=np.bytes_(raw), dtype=fixed)
    ds.attrs["units"] = ""
    return ds


def number(group: h5py.Group, name: str, value: Any, units: str, dtype: str = "f8") -> h5py.Dataset:
    """A numeric dataset with ``@units``."""
    ds = group.create_dataset(name, data=np.asarray(value, dtype=dtype))
    ds.attrs["units"] = units
    return ds


def _scalar_dataset(group: h5py.Group, key: str, value: Any) -> None:
    if isinstance(value, bool):
        number(group, key, value, "", dtype="?")
    elif isinstance(value, (int, float, np.integer, np.floating)):
        number(group, key, float(value), unit_for_key(key))
    elif isinstance(value, str):
        text(group, key, value)
    else:
        text(group, key + "_json", to_json(value, field=key))


def _collection(parent: h5py.Group, name: str, nx_class: str) -> h5py.Group:
    g = parent.create_group(name)
    g.attrs["NX_class"] = nx_class
    return g


def write_sensor(instrument: h5py.Group, spec: ChannelSpec) -> None:
    """One NXsensor group holding everything needed to turn volts into ``spec.unit``."""
    g = _collection(instrument, spec.name, "NXsensor")
    text(g, "name", spec.name)
    text(g, "type", spec.sensor)
    text(g, "measurement", spec.quantity)
    text(g, "unit", spec.unit)
    number(g, "sensitivity", spec.sensitivity, f"{spec.unit}/V")
    number(g, "range", spec.range_v, "V")
    text(g, "coupling", spec.coupling)
    number(g, "iepe", spec.iepe, "", dtype="?")
    text(g, "physical_channel", spec.physical_channel)
    cal = np.array(spec.calibration, dtype=float).reshape(-1, 2)
    number(g, "calibration_frequency", cal[:, 0], "Hz")
    number(g, "calibration_sensitivity", cal[:, 1], f"{spec.unit}/V")
    ph = np.array(spec.calibration_phase, dtype=float).reshape(-1, 3)
    number(g, "calibration_phase_frequency", ph[:, 0], "Hz")
    number(g, "calibration_phase", ph[:, 1], "degree")
    number(g, "calibration_phase_uncertainty", ph[:, 2], "degree")


def read_sensor(g: h5py.Group) -> ChannelSpec:
    """The :class:`ChannelSpec` stored by :func:`write_sensor`."""

    def s(key: str) -> str:
        v = g[key][()]
        return v.decode() if isinstance(v, bytes) else str(v)

    freq = np.asarray(g["calibration_frequency"][()], dtype=float).ravel()
    sens = np.asarray(g["calibration_sensitivity"][()], dtype=float).ravel()
    phase = tuple(zip(*(np.asarray(g[k][()], dtype=float).ravel().tolist()
                        for k in ("calibration_phase_frequency", "calibration_phase",
                                  "calibration_phase_uncertainty")))) \
        if "calibration_phase" in g else ()          # files written before phases
    return ChannelSpec(name=s("name"), sensor=s("type"), quantity=s("measurement"),
                       unit=s("unit"), sensitivity=float(g["sensitivity"][()]),
                       range_v=float(g["range"][()]), coupling=s("coupling"),
                       iepe=bool(g["iepe"][()]), physical_channel=s("physical_channel"),
                       calibration=tuple((float(a), float(b)) for a, b in zip(freq, sens)),
                       calibration_phase=phase)


def channel_metadata(metadata: dict[str, Any], channels: list[ChannelSpec],
                     quantities: dict[str, str] | None = None) -> dict[str, Any]:
    """``channel_quantities`` (name -> quantity: ``quantities``, else the specs'),
    ``drive_channels`` and ``response_channels`` of a run (the metadata's own lists where
    it gives them, else the rules of :mod:`labjoint.storage.roles`)."""
    md = dict(metadata)
    md["channel_quantities"] = dict(quantities) if quantities is not None else \
        {c.name: c.quantity for c in channels}
    roles = channel_roles(md, [c.name for c in channels])
    return {"channel_quantities": md["channel_quantities"],
            "drive_channels": list(roles.drives), "response_channels": list(roles.responses)}


def check_channels(channels: list[ChannelSpec]) -> None:
    """Channel list usable in a run file: non-empty, unique names, none called ``time``."""
    names = [c.name for c in channels]
    if not names:
        raise InputError("a run needs at least one channel", field="channels")
    if len(set(names)) != len(names):
        raise InputError(f"channel names must be unique, got {names}", field="channels")
    if "time" in names:
        raise InputError("'time' is reserved for the time axis", field="channels")


def _resizable(group: h5py.Group, name: str, units: str, dtype: Any, *, shape=(0,),
               chunks=(CHUNK_SAMPLES,), compress: bool = False) -> h5py.Dataset:
    maxshape = (None,) + tuple(shape[1:])
    kw = dict(compression="gzip", compression_opts=1, shuffle=True) if compress else {}
    ds = group.create_dataset(name, shape=shape, maxshape=maxshape, chunks=chunks,
                              dtype=dtype, **kw)
    ds.attrs["units"] = units
    return ds


def create_layout(f: h5py.File, *, name: str, uid: str, channels: list[ChannelSpec],
                  sample_rate_hz: float, metadata: dict[str, Any], source: str,
                  signal: str | None = None, data_units: str | None = None,
                  writer_pid: int = 0, writer_host: str = "") -> None:
    """Create every group, attribute and (empty, resizable) dataset of a run file.

    ``data_units`` is "V" for acquired runs; None stores each channel in its own
    physical unit (imported runs, unity calibration).
    """
    check_channels(channels)
    if not (sample_rate_hz > 0 and math.isfinite(sample_rate_hz)):
        raise InputError(f"sample rate must be positive, got {sample_rate_hz}", field="sample_rate_hz")

    md = dict(metadata)
    md["sample_rate_hz"] = float(sample_rate_hz)
    md.setdefault("software_version", __version__)
    f.attrs["NX_class"] = "NXroot"
    f.attrs["default"] = "entry"
    f.attrs["creator"] = f"labjoint {__version__}"
    e = _collection(f, "entry", "NXentry")
    e.attrs["default"] = "data"
    e.attrs["labjoint_format"] = FORMAT_VERSION
    e.attrs["labjoint_source"] = source
    for key in KNOWN_KEYS:
        v = md.get(key)
        if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool):
            e.attrs[key] = float(v)
    text(e, "title", name)
    text(e, "entry_identifier", uid)
    text(e, "start_time", str(md.get("start_time", "")))
    text(e, "end_time", "", fixed=TIME_DTYPE)
    text(e, "status", "running", fixed=STATUS_DTYPE)
    number(e, "n_samples", -1, "", dtype="<i8")
    text(e, "software_version", str(md["software_version"]))
    prog = text(e, "program_name", "labjoint")
    prog.attrs["version"] = __version__
    text(e, "plan", str(md.get("plan", "")))
    step = md.get("plan_step", -1)
    if isinstance(step, (int, np.integer)) and not isinstance(step, bool):
        number(e, "plan_step", step, "", dtype="<i8")
    else:
        text(e, "plan_step", str(step))
    md.update(channel_metadata(md, channels))
    text(e, "metadata_json", to_json(md))

    sample = _collection(e, "sample", "NXsample")
    text(sample, "name", str(md.get("sample", "bolted lap joint")))
    if "torque_nm" in md:
        number(sample, "bolt_torque", float(md["torque_nm"]), "N*m")
    if "normal_force_n" in md:
        number(sample, "normal_force", float(md["normal_force_n"]), "N")

    inst = _collection(e, "instrument", "NXinstrument")
    for key in ("generator", "daq"):
        sub = _collection(inst, key, "NXcollection")
        value = md.get(key)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            value = dataclasses.asdict(value)
        if isinstance(value, dict):
            for k, v in value.items():
                _scalar_dataset(sub, str(k).replace("/", "_"), v)
    number(inst["daq"], "sample_rate", float(sample_rate_hz), "Hz")
    for spec in channels:
        write_sensor(inst, spec)

    data = _collection(e, "data", "NXdata")
    names = [c.name for c in channels]
    sig = signal if signal in names else names[0]
    data.attrs["signal"] = sig
    data.attrs["axes"] = "time"
    data.attrs["time_indices"] = 0
    data.attrs["auxiliary_signals"] = [n for n in names if n != sig]
    data.attrs["labjoint_channels"] = names  # channel (row) order of the DAQ
    t = _resizable(data, "time", "s", "f8", compress=True)
    t.attrs["long_name"] = "time from the first sample (DAQ sample counter / sample rate)"
    for spec in channels:
        ds = _resizable(data, spec.name, data_units or spec.unit, "f8")
        ds.attrs["long_name"] = f"{spec.name} ({spec.quantity}, {spec.sensor})"
        ds.attrs["quantity"] = spec.quantity
        ds.attrs["physical_units"] = spec.unit

    acq = _collection(e, "acquisition", "NXcollection")
    _resizable(acq, "gaps", "", "<i8", shape=(0, 2), chunks=(64, 2))
    _resizable(acq, "events", "", EVENT_DTYPE, chunks=(16,), compress=True)
    number(acq, "continuous", True, "", dtype="?")
    number(acq, "writer_pid", writer_pid, "", dtype="<i8")
    text(acq, "writer_host", writer_host)
    _collection(e, "processed", "NXcollection")


def event_rows(kind: str, name: str, sample: int, payload: str) -> np.ndarray:
    """Rows of the ``events`` table holding ``payload`` (split into 1 KiB parts)."""
    raw = payload.encode()
    kb, nb = kind.encode(), name.encode()
    if len(nb) > 64:
        raise InputError(f"event name longer than 64 bytes: {name!r}", field="name")
    parts = [raw[i:i + EVENT_TEXT_BYTES] for i in range(0, len(raw), EVENT_TEXT_BYTES)] or [b""]
    rows = np.zeros(len(parts), dtype=EVENT_DTYPE)
    for i, p in enumerate(parts):
        rows[i] = (kb, nb, sample, i, len(parts), p)
    return rows


def parse_events(rows: np.ndarray) -> list[dict[str, Any]]:
    """Events from the table, multi-part payloads joined; a torn last event is dropped."""
    out: list[dict[str, Any]] = []
    i = 0
    while i < len(rows):
        n = int(rows[i]["nparts"])
        chunk = rows[i:i + n]
        if n < 1 or len(chunk) < n:
            break
        payload = b"".join(bytes(r["text"]) for r in chunk).decode()
        out.append({"kind": rows[i]["kind"].decode(), "name": rows[i]["name"].decode(),
                    "sample": int(rows[i]["sample"]), "data": json.loads(payload) if payload else None})
        i += n
    return out


def append_rows(ds: h5py.Dataset, rows: np.ndarray) -> None:
    """Append ``rows`` along axis 0 of a resizable dataset."""
    n0 = ds.shape[0]
    ds.resize((n0 + len(rows),) + ds.shape[1:])
    ds[n0:] = rows
