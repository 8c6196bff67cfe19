"""What labs export, opened as *tests*: CSV, MATLAB .mat (v5 and v7.3), UFF 58, TDMS, HDF5.

A file holds one or more tests (an HDF5 group, a MAT struct, a TDMS group; a CSV, a UFF
file or an un-grouped file is one test named after the file). A :class:`SourceTest`
gives the test's arrays by the names a channel map uses (``source``), its attributes,
and the sample rate the file itself states (TDMS ``wf_increment``, UFF abscissa
increment). UFF 58 FRF sets come out as :class:`SourceFrf`. Nothing here knows
quantities: the map says what each array is (:mod:`labjoint.storage.channel_map`).
"""

from __future__ import annotations

import fnmatch
import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from labjoint.errors import InputError
from labjoint.storage.h5open import H5_FILE_ERRORS

#: UFF dataset types read (58) or passed over as headers/geometry/units.
UFF_READ, UFF_PASSED = (58,), (15, 18, 82, 151, 164, 2411, 2412, 2420)
#: UFF 58 function types: 1 time response, 4 frequency response function.
UFF_TIME, UFF_FRF = 1, 4


@dataclass
class SourceFrf:
    """One FRF of a file: frequency lines (Hz), complex values, a label from the file."""

    name: str
    frequency_hz: np.ndarray
    values: np.ndarray
    label: str = ""


@dataclass
class SourceTest:
    """One test of a file: its arrays by source name, attributes, the file's rate."""

    file: Path
    name: str
    get: Callable[[str], np.ndarray | None]
    names: Callable[[], list[str]]
    attrs: dict[str, Any] = field(default_factory=dict)
    sample_rate_hz: float | None = None
    frfs: list[SourceFrf] = field(default_factory=list)
    metadata: dict[str, Any] = field(default_factory=dict)   # the file's own (CSV '#' lines)

    def array(self, source: str, channel: str, column: int | None = None) -> np.ndarray:
        """The 1-D array ``source`` (column ``column`` of a 2-D one), or InputError naming
        the file, test and channel."""
        a = self.get(source)
        if a is None:
            raise InputError(f"no channel {source!r} in test {self.name!r}; it has {self.names()}",
                             file=str(self.file), field=channel)
        a = np.asarray(a)
        if column is not None and a.ndim == 2:
            if not 0 <= column < a.shape[1]:
                raise InputError(f"column {column} outside the {a.shape[1]} of {source!r}",
                                 file=str(self.file), field=channel)
            a = a[:, column]
        if a.ndim == 2 and 1 in a.shape:
            a = a.ravel()
        if a.ndim != 1 or not np.issubdtype(a.dtype, np.number):
            raise InputError(f"{source!r} in test {self.name!r} is not a 1-D numeric array "
                             f"(shape {a.shape}, {a.dtype})", file=str(self.file), field=channel)
        return a


def _pick(names: list[str], patterns: list[str]) -> list[str]:
    return [n for n in names if any(fnmatch.fnmatchcase(n, p) for p in patterns)]


def _attr(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode(errors="replace")
    if isinstance(v, np.ndarray) and v.size == 1:
        return _attr(v.reshape(()).item())
    if isinstance(v, np.generic):
        return v.item()
    return v


def read_tests(path: Path, fmt: str, patterns: list[str], options: dict[str, Any]) -> list[SourceTest]:
    """The tests of ``path`` (format ``fmt``); ``patterns`` select groups/structs."""
    if not path.is_file():
        raise InputError("no such file", file=str(path))
    reader = {"csv": _csv, "mat": _mat, "uff": _uff, "tdms": _tdms, "hdf5": _hdf5}[fmt]
    return reader(path, patterns, options)


# -- CSV -------------------------------------------------------------------------------
def _csv(path: Path, patterns: list[str], options: dict[str, Any]) -> list[SourceTest]:
    f = str(path)
    try:
        text = path.read_bytes().decode("utf-8-sig").replace("\r\n", "\n").replace("\r", "\n")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"not a readable UTF-8 text file: {exc}", file=f) from None
    lines = text.split("\n")
    attrs: dict[str, Any] = {}
    i = 0
    while i < len(lines) and (not lines[i].strip() or lines[i].lstrip().startswith("#")):
        key, sep, value = lines[i].lstrip()[1:].partition(":")
        if sep and key.strip():
            attrs[key.strip()] = value.strip()
        i += 1
    if i >= len(lines):
        raise InputError("no header row", file=f, line=i)
    delim = str(options.get("delimiter", ","))
    header = [c.strip().strip('"') for c in lines[i].split(delim)]
    body = "\n".join(lines[i + 1:]).rstrip()
    if not body:
        raise InputError("no data rows after the header", file=f, line=i + 2)
    try:
        values = np.loadtxt(io.StringIO(body), delimiter=delim, dtype=float, ndmin=2, comments=None)
    except ValueError as exc:
        raise InputError(f"cannot parse the data: {exc}", file=f, line=i + 2) from None
    if values.shape[1] != len(header):
        raise InputError(f"{values.shape[1]} values per row, {len(header)} header names",
                         file=f, line=i + 1)
    cols = {h: values[:, k] for k, h in enumerate(header)}
    return [SourceTest(path, path.stem, cols.get, lambda: list(cols), metadata=attrs)]


# -- MATLAB ----------------------------------------------------------------------------
def _mat(path: Path, patterns: list[str], options: dict[str, Any]) -> list[SourceTest]:
    import h5py

    if h5py.is_hdf5(path):                 # MATLAB v7.3 files are HDF5
        return _mat73(path, patterns)
    import scipy.io

    try:
        d = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)
    except (ValueError, TypeError, OSError, NotImplementedError) as exc:
        raise InputError(f"not a readable MATLAB file: {exc}", file=str(path)) from None
    variables = {k: v for k, v in d.items() if not k.startswith("__")}
    if not patterns:
        return [SourceTest(path, path.stem, variables.get, lambda: list(variables))]
    out = []
    for name in _pick(list(variables), patterns):
        s = variables[name]
        if not hasattr(s, "_fieldnames"):
            continue
        fields = {k: getattr(s, k) for k in s._fieldnames}
        arrays = {k: v for k, v in fields.items() if isinstance(v, np.ndarray) and v.size > 1}
        attrs = {k: _attr(v) for k, v in fields.items() if k not in arrays}
        out.append(SourceTest(path, name, arrays.get, lambda a=arrays: list(a), attrs))
    return out


def _mat73(path: Path, patterns: list[str]) -> list[SourceTest]:
    import h5py

    def load(g: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        arrays, attrs = {}, {}
        for k, v in g.items():
            if not isinstance(v, h5py.Dataset) or k.startswith("#"):
                continue
            cls = _attr(v.attrs.get("MATLAB_class", b""))
            a = v[()]
            if cls == "char":
                attrs[k] = "".join(chr(c) for c in np.asarray(a).ravel())
            elif np.asarray(a).size == 1:
                attrs[k] = _attr(a)
            else:
                arrays[k] = np.asarray(a).T      # MATLAB stores column-major
        return arrays, attrs

    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"not a readable MATLAB v7.3 file: {exc}", file=str(path)) from None
    with f:
        if not patterns:
            arrays, attrs = load(f)
            return [SourceTest(path, path.stem, arrays.get, lambda: list(arrays), attrs)]
        out = []
        for name in _pick([k for k, v in f.items() if isinstance(v, h5py.Group)], patterns):
            arrays, attrs = load(f[name])
            out.append(SourceTest(path, name, arrays.get, lambda a=arrays: list(a), attrs))
        return out


#: Values of one dataset an import reads (1000 s at 50 kS/s; 400 MB as float64).
MAX_IMPORT_SAMPLES = 50_000_000


# -- HDF5 ------------------------------------------------------------------------------
def _hdf5(path: Path, patterns: list[str], options: dict[str, Any]) -> list[SourceTest]:
    import h5py

    try:
        f = h5py.File(path, "r")
    except H5_FILE_ERRORS as exc:
        raise InputError(f"not a readable HDF5 file: {exc}", file=str(path)) from None
    with f:
        groups = [(path.stem, "/")] if not patterns else \
            [(k, k) for k in _pick([k for k, v in f.items() if isinstance(v, h5py.Group)], patterns)]
        out = []
        for name, where in groups:
            names: list[str] = []
            f[where].visititems(lambda k, v, a=names: a.append(k)
                                if isinstance(v, h5py.Dataset) and v.ndim <= 2 else None)
            attrs = {k: _attr(v) for k, v in f[where].attrs.items()}

            def get(k: str, where: str = where, names: list[str] = names) -> np.ndarray | None:
                if k not in names:                # read on demand: one test in memory at a time
                    return None
                with h5py.File(path, "r") as fh:
                    ds = fh[where][k]              # checked as declared, before it is read
                    if ds.dtype.kind not in "biuf":
                        what = ("complex values (a complex channel is refused, not "
                                "truncated)" if ds.dtype.kind == "c" else f"{ds.dtype} values")
                        raise InputError(f"dataset {k!r} holds {what}, not real numbers",
                                         file=str(path), field=k)
                    if ds.size > MAX_IMPORT_SAMPLES:
                        raise InputError(f"dataset {k!r} declares {ds.size:.3g} values; at most "
                                         f"{MAX_IMPORT_SAMPLES:.3g} are imported", file=str(path),
                                         field=k)
                    try:
                        return ds[()]
                    except H5_FILE_ERRORS as exc:
                        raise InputError(f"cannot read dataset {k!r}: {exc}", file=str(path),
                                         field=k) from None
            out.append(SourceTest(path, name, get, lambda a=names: sorted(a), attrs))
        return out


# -- TDMS ------------------------------------------------------------------------------
def _tdms(path: Path, patterns: list[str], options: dict[str, Any]) -> list[SourceTest]:
    import logging

    from nptdms import TdmsFile

    # nptdms logs (to stderr) what it could not parse and carries on: collect it instead,
    # and refuse a file whose header it does not recognise
    seen: list[str] = []
    grab = logging.Handler(logging.WARNING)
    grab.emit = lambda record: seen.append(record.getMessage())  # type: ignore[method-assign]
    logs = [logging.getLogger(n) for n in ("nptdms", "nptdms.reader")]
    old = [(g.propagate, list(g.handlers)) for g in logs]
    for g in logs:
        g.handlers, g.propagate = [grab] if g.name == "nptdms" else [], g.name != "nptdms"
    try:
        f = TdmsFile.read(path)
    except Exception as exc:  # nptdms raises ValueError, KeyError, struct errors ...
        raise InputError(f"not a readable TDMS file: {exc}", file=str(path)) from None
    finally:
        for g, (prop, handlers) in zip(logs, old):
            g.propagate, g.handlers = prop, handlers
    if any("version" in m.lower() or "incomplete" in m.lower() for m in seen):
        raise InputError(f"not a readable TDMS file: {'; '.join(dict.fromkeys(seen))}",
                         file=str(path))
    groups = f.groups() if not patterns else [g for g in f.groups() if _pick([g.name], patterns)]
    everything = not patterns
    out = []
    for name, chans in ([(path.stem, [c for g in f.groups() for c in g.channels()])] if everything
                        else [(g.name, g.channels()) for g in groups]):
        arrays = {(f"{c.group_name}/{c.name}" if everything else c.name): c for c in chans}
        incs = {float(c.properties["wf_increment"]) for c in chans
                if c.properties.get("wf_increment")}
        fs = 1.0 / incs.pop() if len(incs) == 1 else None
        out.append(SourceTest(path, name,
                              lambda k, a=arrays: None if k not in a else np.asarray(a[k][:]),
                              lambda a=arrays: list(a), {}, fs))
    return out


# -- UFF -------------------------------------------------------------------------------
def _uff(path: Path, patterns: list[str], options: dict[str, Any]) -> list[SourceTest]:
    import pyuff

    f = str(path)
    try:
        u = pyuff.UFF(f)
        types = [int(t) for t in u.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exceptions on unreadable files
        raise InputError(f"not a readable UFF file: {exc}", file=f) from None
    for k, t in enumerate(types):
        if t not in UFF_READ + UFF_PASSED:
            raise InputError(f"UFF dataset {k + 1} has type {t}, which labjoint does not read "
                             "(type 58 time records and FRFs)", file=f, field=f"set {k + 1}")
    if not types:
        raise InputError("no UFF datasets in the file", file=f)
    keep = [k for k, t in enumerate(types) if t == 58]
    try:
        sets = u.read_sets(keep) if keep else []
    except Exception as exc:
        raise InputError(f"cannot read the UFF 58 sets: {exc}", file=f) from None
    sets = [sets] if isinstance(sets, dict) else list(sets)
    arrays: dict[str, np.ndarray] = {}
    frfs: list[SourceFrf] = []
    incs = set()
    for k, s in zip(keep, sets):
        ft = int(s.get("func_type", 0))
        label = str(s.get("id1", "")).strip()
        key = label or f"{s.get('rsp_node')}:{s.get('rsp_dir')}"
        if ft == UFF_TIME:
            arrays[key] = np.asarray(s["data"], dtype=float)
            arrays.setdefault(f"{s.get('rsp_node')}:{s.get('rsp_dir')}", arrays[key])
            inc = float(s.get("abscissa_inc") or 0.0)
            if int(s.get("abscissa_spacing", 1)) != 1 or not (inc > 0 and math.isfinite(inc)):
                raise InputError("UFF time record without an even abscissa increment",
                                 file=f, field=key)
            incs.add(round(inc, 15))
        elif ft == UFF_FRF:
            frfs.append(SourceFrf(key, np.asarray(s["x"], dtype=float),
                                  np.asarray(s["data"], dtype=complex), label))
        else:
            raise InputError(f"UFF 58 function type {ft} is not read (1 time response, "
                             "4 FRF)", file=f, field=f"set {k + 1} ({key})")
    if len(incs) > 1:
        raise InputError(f"UFF time records with different increments {sorted(incs)}",
                         file=f, field="abscissa_inc")
    fs = 1.0 / incs.pop() if incs else None
    return [SourceTest(path, path.stem, arrays.get, lambda: list(arrays), {}, fs, frfs)]
