"""Channel maps: which column, dataset or variable of a lab's export is which channel,
its quantity, its unit and its role; which tests of a multi-test file to import; where
each test's metadata comes from. One map serves a whole directory of files.

::

    format = "hdf5"                      # csv | mat | uff | tdms | hdf5 (default: suffix)
    [tests]                              # multi-test files (HDF5 groups, MAT structs)
    include = ["Sine_*", "Rand_*"]       # name patterns (fnmatch); one run file per test
    skip = []                            # patterns left out
    frf = ["frf_*"]                      # tests holding FRFs (frequency, real, imaginary)
    [time]
    source = "time_s"                    # the time column/dataset (s), checked uniform;
    units = "s"                          # or sample_rate_hz = 1024.0, or
    sample_rate_attr = "sample_rate_hz"  # a test attribute holding the rate
    [channels.input_V]                   # the stored channel's name
    source = "input_V"                   # column, dataset (in the test) or variable
    quantity = "voltage"                 # displacement, velocity, acceleration, force,
    units = "V"                          #   voltage, or another (kept as given)
    role = "drive"                       # drive | response | other (default: response
    scale = 1.0                          #   for motion, else other); optional factor
    [metadata]                           # fixed values for every test
    torque_nm = 5.0
    [metadata.attrs]                     # key = test attribute to copy (as a number if
    torque_nm = "torque_nm"              #   it reads as one)
    [metadata.name]                      # values from the test's name
    pattern = 'Sine_(?P<frequency_hz>\\d+(?:p\\d+)?)Hz'
    decimal = "p"                        # "05p5" -> 5.5
    [metadata.table]                     # a per-file/per-test table (CSV: a column
    path = "tests.csv"                   #   `file` or `test`, then one per key)
    [frf]                                # for the [tests].frf tests and UFF FRFs
    frequency = "frequency_hz"           # dataset names in an FRF test
    real = "re"
    imag = "im"
    response = {name = "laser", quantity = "velocity", units = "m/s"}
    drive = {name = "input_V", quantity = "voltage", units = "V"}

A quantity is never guessed from a name: each channel states it, and its unit must fit
(:mod:`labjoint.storage.quantities`). Maps of the older form (columns
``displacement_m``/``force_N`` with ``scale``, :mod:`labjoint.storage.foreign`) are
recognised by :func:`is_legacy`.
"""

from __future__ import annotations

import csv
import fnmatch
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from labjoint.errors import InputError
from labjoint.storage.quantities import MOTION_QUANTITIES, to_si

FORMATS = ("csv", "mat", "uff", "tdms", "hdf5")
SUFFIX_FORMATS = {".csv": "csv", ".txt": "csv", ".mat": "mat", ".uff": "uff", ".unv": "uff",
                  ".tdms": "tdms", ".h5": "hdf5", ".hdf5": "hdf5"}
ROLES = ("drive", "response", "other")


@dataclass(frozen=True)
class MapChannel:
    """One channel of a map: stored ``name``, where it is, quantity, SI factor, role."""

    name: str
    source: str
    quantity: str
    units: str            # as written in the map
    si_units: str
    factor: float         # scale x unit conversion: stored = raw * factor
    role: str
    column: int | None = None   # the column of a 2-D dataset (older maps' ``column = k``)


@dataclass
class ChannelMap:
    """A checked channel map (module doc)."""

    source: str
    format: str | None
    channels: list[MapChannel]
    include: list[str] = field(default_factory=list)
    skip: list[str] = field(default_factory=list)
    frf_tests: list[str] = field(default_factory=list)
    time: dict[str, Any] = field(default_factory=dict)
    metadata: dict[str, Any] = field(default_factory=dict)
    attrs: dict[str, str] = field(default_factory=dict)
    name_pattern: re.Pattern | None = None
    decimal: str = "p"
    table: dict[str, dict[str, Any]] = field(default_factory=dict)
    frf: dict[str, Any] = field(default_factory=dict)

    def selects(self, test: str) -> bool:
        """Whether a time-record test called ``test`` is imported."""
        if any(fnmatch.fnmatchcase(test, p) for p in self.skip + self.frf_tests):
            return False
        return not self.include or any(fnmatch.fnmatchcase(test, p) for p in self.include)

    def is_frf(self, test: str) -> bool:
        """Whether ``test`` is one of the map's FRF tests."""
        return any(fnmatch.fnmatchcase(test, p) for p in self.frf_tests) and \
            not any(fnmatch.fnmatchcase(test, p) for p in self.skip)

    def test_metadata(self, test: str, file: Path, attrs: dict[str, Any],
                      own: dict[str, Any] | None = None) -> dict[str, Any]:
        """Metadata of one test: the map's fixed values, then the file's own metadata
        (``own``: a CSV's ``# key: value`` lines), attributes, its name, the table."""
        md = dict(self.metadata)
        md.update({k: _number_or_text(v) for k, v in (own or {}).items()})
        for key, attr in self.attrs.items():
            if attr in attrs:
                md[key] = _number_or_text(attrs[attr])
        if self.name_pattern is not None:
            m = self.name_pattern.search(test)
            if m:
                for key, value in m.groupdict().items():
                    if value is not None:
                        md[key] = _number_or_text(value.replace(self.decimal, ".")
                                                  if self.decimal else value)
        for key in (test, file.name, file.stem, str(file)):
            if key in self.table:
                md.update(self.table[key])
                break
        return md


def _number_or_text(v: Any) -> Any:
    if isinstance(v, bytes):
        v = v.decode(errors="replace")
    try:
        x = float(v)
    except (TypeError, ValueError):
        return str(v) if not isinstance(v, (int, float)) else v
    return x if math.isfinite(x) else str(v)


def is_legacy(m: dict[str, Any]) -> bool:
    """An older-form map: channels keyed ``name_unit`` with no ``quantity``."""
    chans = m.get("channels")
    return isinstance(chans, dict) and bool(chans) and \
        all(isinstance(c, dict) and "quantity" not in c for c in chans.values())


def read_toml(spec: str | Path) -> dict[str, Any]:
    """The TOML text of a map file, parsed (InputError naming the file otherwise)."""
    p = Path(spec)
    try:
        return tomllib.loads(p.read_text())
    except OSError as exc:
        raise InputError(f"cannot read the channel map ({exc.strerror})", file=str(p)) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"not valid TOML: {exc}", file=str(p)) from None


def _strings(v: Any, src: str, fld: str) -> list[str]:
    if isinstance(v, str):
        return [v]
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        raise InputError("must be a list of name patterns", file=src, field=fld)
    return list(v)


def _channel(name: str, c: Any, src: str) -> MapChannel:
    if not isinstance(c, dict):
        raise InputError(f"[channels.{name}] must be a table", file=src, field=name)
    if not name.replace("_", "").isalnum() or name.lower() == "time":
        raise InputError(f"channel name {name!r} must be letters, digits and '_' (not 'time')",
                         file=src, field=name)
    if "quantity" not in c:
        raise InputError("the map does not say what this channel measures: give quantity "
                         "(and units)", file=src, field=name)
    if "units" not in c:
        raise InputError("the map gives no units for this channel", file=src, field=name)
    quantity = str(c["quantity"]).strip().lower()
    factor, si = to_si(quantity, str(c["units"]), channel=name, file=src)
    scale = c.get("scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) \
            or not math.isfinite(scale) or scale == 0:
        raise InputError(f"scale must be a finite non-zero number, got {scale!r}", file=src,
                         field=f"{name}.scale")
    role = str(c.get("role") or ("response" if quantity in MOTION_QUANTITIES else "other"))
    if role not in ROLES:
        raise InputError(f"role must be one of {ROLES}, got {role!r}", file=src,
                         field=f"{name}.role")
    source = c.get("source", name)
    if not isinstance(source, str) or not source:
        raise InputError("source must be a column, dataset or variable name", file=src,
                         field=f"{name}.source")
    return MapChannel(name, source, quantity, str(c["units"]), si, float(scale) * factor, role)


def _table(t: Any, base: Path | None, src: str) -> dict[str, dict[str, Any]]:
    if not isinstance(t, dict) or "path" not in t:
        raise InputError("[metadata.table] needs path = 'table.csv'", file=src,
                         field="metadata.table")
    p = Path(str(t["path"]))
    if not p.is_absolute() and base is not None:
        p = base / p
    try:
        rows = list(csv.DictReader(p.read_text().splitlines()))
    except OSError as exc:
        raise InputError(f"cannot read the metadata table ({exc.strerror})", file=str(p)) from None
    key = next((k for k in ("file", "test") if rows and k in rows[0]), None)
    if key is None:
        raise InputError("the metadata table needs a column 'file' or 'test'", file=str(p),
                         field="file")
    out: dict[str, dict[str, Any]] = {}
    for i, row in enumerate(rows, start=2):
        name = (row.pop(key) or "").strip()
        if not name or name in out:
            raise InputError(f"empty or repeated {key} {name!r}", file=str(p), line=i, column=key)
        out[name] = {k.strip(): _number_or_text(v.strip()) for k, v in row.items()
                     if k and v is not None and v.strip() != ""}
    return out


def load_table(path: str | Path) -> dict[str, dict[str, Any]]:
    """A per-file/per-test metadata table (CSV: a column ``file`` or ``test``, then keys)."""
    return _table({"path": str(path)}, None, str(path))


def load_channel_map(spec: str | Path | dict[str, Any], *, base: Path | None = None) -> ChannelMap:
    """A :class:`ChannelMap` from a TOML file or a dict, checked (InputError naming the
    map and the channel or field)."""
    if isinstance(spec, dict):
        m, src = spec, "inline map"
    else:
        m, src = read_toml(spec), str(spec)
        base = base or Path(spec).parent
    fmt = m.get("format")
    if fmt is not None and fmt not in FORMATS:
        raise InputError(f"format must be one of {FORMATS}, got {fmt!r}", file=src, field="format")
    chans = m.get("channels", {} if isinstance(m.get("frf"), dict) else None)
    if not isinstance(chans, dict) or not (chans or m.get("frf")):
        raise InputError("the map needs a [channels] table (or, for FRFs only, [frf])",
                         file=src, field="channels")
    channels = [_channel(str(k), v, src) for k, v in chans.items()]
    tests = m.get("tests", {})
    md = dict(m.get("metadata", {}))
    attrs = md.pop("attrs", {})
    name = md.pop("name", None)
    table = md.pop("table", None)
    cmap = ChannelMap(src, fmt, channels,
                      include=_strings(tests.get("include", []), src, "tests.include"),
                      skip=_strings(tests.get("skip", []), src, "tests.skip"),
                      frf_tests=_strings(tests.get("frf", []), src, "tests.frf"),
                      time=dict(m.get("time", {})), metadata=md,
                      attrs={str(k): str(v) for k, v in dict(attrs).items()},
                      frf=dict(m.get("frf", {})))
    if name is not None:
        try:
            cmap.name_pattern = re.compile(str(name["pattern"]))
        except (KeyError, TypeError, re.error) as exc:
            raise InputError(f"[metadata.name] needs a valid pattern: {exc}", file=src,
                             field="metadata.name") from None
        cmap.decimal = str(name.get("decimal", "p"))
    if table is not None:
        cmap.table = _table(table, base, src)
    fs = cmap.time.get("sample_rate_hz")
    if fs is not None and (isinstance(fs, bool) or not isinstance(fs, (int, float))
                           or not (math.isfinite(fs) and fs > 0)):
        raise InputError(f"sample_rate_hz must be > 0, got {fs!r}", file=src, field="time.sample_rate_hz")
    return cmap
