"""Import what labs export through one channel map: one run file per test.

:func:`import_files` reads every file (a list, or the files of a directory) with one
:class:`~labjoint.storage.channel_map.ChannelMap`, checks every test completely, and
only then writes one run file per test (named after the test: HDF5 group
``Rand_Rand0p25`` -> ``Rand_Rand0p25.h5``), each atomically; if any write fails, the
files of this import already written are removed again. Every channel is stored in SI
with its quantity and unit; the run metadata lists ``drive_channels`` and
``response_channels``.

FRFs (UFF 58 function type 4; HDF5 tests the map lists under ``[tests].frf``) are stored
in a run file of their own, in ``/entry/processed/frf`` with their quantity pair
(response over drive, units e.g. ``m/s/V``): read them with :func:`read_frf`. Such a
file's channels (the FRF's response and drive) hold no samples.

Refused, naming file and channel, before anything is written: a map naming a missing
channel, a unit that does not fit its quantity, a gapped or non-uniform time base,
channels of unequal length (ragged), non-finite samples, a record with no drive channel,
a drive frequency at or above Nyquist, two tests with the same run name.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import h5py
import numpy as np

from labjoint.errors import InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage import layout
from labjoint.storage.channel_map import SUFFIX_FORMATS, ChannelMap
from labjoint.storage.csv_import import safe_name, store_channels
from labjoint.storage.csv_parse import GRID_TOLERANCE, KNOWN_KEYS, RATE_TOLERANCE, STEP_TOLERANCE
from labjoint.storage.quantities import (DRIVE_QUANTITIES, MOTION_QUANTITIES, SI_UNITS, frf_units,
                                          to_si)
from labjoint.storage.reader import open_run
from labjoint.storage.sources import SourceFrf, SourceTest, read_tests

FRF_GROUP = "frf"


@dataclass
class Prepared:
    """One checked test, ready to be written."""

    name: str
    file: Path
    time: np.ndarray
    sample_rate_hz: float
    channels: list[tuple[ChannelSpec, np.ndarray]]
    metadata: dict[str, Any]
    frf: dict[str, Any] | None = None


@dataclass
class Checked:
    """A test that passed every check: its run name, file, and how to read it again
    (only one test's samples are held in memory at a time)."""

    name: str
    file: Path
    read: Callable[[], Prepared]


@dataclass
class ImportResult:
    """Paths written, and tests passed over with the reason."""

    runs: list[Path] = field(default_factory=list)
    skipped: list[dict[str, str]] = field(default_factory=list)


def _spec(name: str, quantity: str, units: str) -> ChannelSpec:
    return ChannelSpec(name=name, sensor="imported", quantity=quantity, unit=units,
                       sensitivity=1.0, range_v=math.inf, coupling="DC")


def expand(files: list[str | Path], cmap: ChannelMap) -> list[Path]:
    """The files to import: each given file, and the importable files of each directory."""
    out: list[Path] = []
    for f in files:
        p = Path(f)
        if p.is_dir():
            fmts = {cmap.format} if cmap.format else set(SUFFIX_FORMATS.values())
            found = sorted(q for q in p.iterdir() if q.is_file()
                           and SUFFIX_FORMATS.get(q.suffix.lower()) in fmts)
            if not found:
                raise InputError("no importable files in the directory", file=str(p))
            out.extend(found)
        else:
            out.append(p)
    return out


def _format(p: Path, cmap: ChannelMap) -> str:
    fmt = cmap.format or SUFFIX_FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise InputError(f"unknown file type {p.suffix!r}: give format in the map", file=str(p),
                         field="format")
    return fmt


def _time_base(test: SourceTest, cmap: ChannelMap, n: int) -> tuple[np.ndarray, float]:
    f, t_cfg = str(test.file), cmap.time
    fs = t_cfg.get("sample_rate_hz")
    if fs is None and "sample_rate_source" in t_cfg:        # a dataset holding the rate
        v = test.get(str(t_cfg["sample_rate_source"]))
        try:
            fs = float(np.ravel(v)[0])
        except (TypeError, ValueError, IndexError):
            raise InputError(f"no numeric {t_cfg['sample_rate_source']!r} in test {test.name!r}",
                             file=f, field="sample_rate_source") from None
    if fs is None and "sample_rate_attr" in t_cfg:
        v = test.attrs.get(str(t_cfg["sample_rate_attr"]))
        try:
            fs = float(v)
        except (TypeError, ValueError):
            raise InputError(f"test {test.name!r} has no numeric attribute "
                             f"{t_cfg['sample_rate_attr']!r}", file=f, field="sample_rate_attr") from None
    if "source" not in t_cfg:
        fs = fs if fs is not None else test.sample_rate_hz
        if fs is None or not (fs > 0 and math.isfinite(fs)):
            raise InputError("no sample rate: give [time] source or sample_rate_hz in the map",
                             file=f, field="time")
        return np.arange(n) / float(fs), float(fs)
    k, _ = to_si("time", str(t_cfg.get("units", "s")), channel="time", file=cmap.source)
    t = test.array(str(t_cfg["source"]), "time").astype(float) * k
    if t.size != n:
        raise InputError(f"time has {t.size} samples, the channels {n}: refused, not truncated",
                         file=f, field="time")
    if n < 2 or not np.all(np.isfinite(t)):
        raise InputError("time needs at least 2 finite samples", file=f, field="time")
    d = np.diff(t)
    dt = (t[-1] - t[0]) / (n - 1)
    bad = np.flatnonzero((d <= 0) | (np.abs(d - dt) > STEP_TOLERANCE * dt))
    if bad.size == 0:
        bad = np.flatnonzero(np.abs(t - t[0] - dt * np.arange(n)) > GRID_TOLERANCE * dt)
    if bad.size:
        k0 = int(bad[0])
        raise InputError(f"gapped or non-uniform time base in test {test.name!r} at sample "
                         f"{k0 + 1} (t = {t[min(k0 + 1, n - 1)]:.9g} s; mean step {dt:.6g} s)",
                         file=f, field="time")
    if fs is not None and abs(fs * dt - 1.0) > RATE_TOLERANCE:
        raise InputError(f"sample rate {fs:g} Hz disagrees with the time base ({1 / dt:.6g} Hz)",
                         file=f, field="sample_rate_hz")
    return t, float(fs if fs is not None else 1.0 / dt)


def _check_metadata(md: dict[str, Any], fs: float, f: str) -> None:
    for k in KNOWN_KEYS:
        if k in md and (isinstance(md[k], bool) or not isinstance(md[k], (int, float))
                        or not math.isfinite(md[k])):
            raise InputError(f"{k} must be a number, got {md[k]!r}", file=f, field=k)
    drive = md.get("frequency_hz")
    if drive is not None and not 0 < drive < fs / 2:
        raise InputError(f"frequency_hz {drive:g} Hz is not between 0 and the Nyquist "
                         f"frequency {fs / 2:g} Hz", file=f, field="frequency_hz")


def prepare_record(test: SourceTest, cmap: ChannelMap) -> Prepared:
    """A time-record test checked and converted to SI (module doc for the refusals)."""
    f = str(test.file)
    if not any(c.role == "drive" for c in cmap.channels):
        raise InputError("no drive channel: the map gives no channel role = \"drive\" (a "
                         "measured force or a voltage)", file=f, field=cmap.source)
    raw = {c.name: test.array(c.source, c.name, c.column) for c in cmap.channels}
    lengths = {k: v.size for k, v in raw.items()}
    n = max(lengths.values())
    short = [k for k, v in lengths.items() if v != n]
    if short:
        raise InputError(f"ragged channels (unequal length {lengths}) in test {test.name!r}: "
                         "refused, not truncated", file=f, field=short[0])
    chans = []
    for c in cmap.channels:
        x = raw[c.name].astype(np.float64) * c.factor
        if not np.all(np.isfinite(x)):
            k = int(np.flatnonzero(~np.isfinite(x))[0])
            raise InputError(f"sample {k} of test {test.name!r} is not a finite number",
                             file=f, field=c.name)
        chans.append((_spec(c.name, c.quantity, c.si_units), x))
    t, fs = _time_base(test, cmap, n)
    md = cmap.test_metadata(test.name, test.file, test.attrs, test.metadata)
    _check_metadata(md, fs, f)
    md.update(source_test=test.name, channel_map=cmap.source,
              source_units={c.name: c.units for c in cmap.channels},
              drive_channels=[c.name for c in cmap.channels if c.role == "drive"],
              response_channels=[c.name for c in cmap.channels if c.role == "response"])
    if test.frfs:
        md["record"] = "time+frf"
    return Prepared(safe_name(test.name), test.file, t, fs, chans, md,
                    _frf(test.frfs, cmap, test) if test.frfs else None)


def _frf_side(cmap: ChannelMap, side: str, allowed: tuple[str, ...]) -> tuple[str, str, float]:
    """(channel name, quantity, factor to SI) of the FRF's response or drive, from the map."""
    d = cmap.frf.get(side)
    if not isinstance(d, dict) or "quantity" not in d or "units" not in d:
        raise InputError(f"the map's [frf] needs {side} = {{name, quantity, units}}: an FRF's "
                         "quantity pair is never guessed", file=cmap.source, field=f"frf.{side}")
    name = str(d.get("name", side))
    q = str(d["quantity"]).lower()
    if q not in allowed:
        raise InputError(f"an FRF's {side} is one of {allowed}, not {q!r}", file=cmap.source,
                         field=f"frf.{side}")
    k, _ = to_si(q, str(d["units"]), channel=name, file=cmap.source)
    return name, q, k


def _frf(frfs: list[SourceFrf], cmap: ChannelMap, test: SourceTest) -> dict[str, Any]:
    f = str(test.file)
    rname, rq, kr = _frf_side(cmap, "response", MOTION_QUANTITIES)
    dname, dq, kd = _frf_side(cmap, "drive", DRIVE_QUANTITIES)
    freq = frfs[0].frequency_hz
    for fr in frfs:
        if fr.frequency_hz.shape != freq.shape or not np.allclose(fr.frequency_hz, freq):
            raise InputError("FRFs of one test on different frequency lines", file=f, field=fr.name)
        if not (np.all(np.isfinite(fr.values)) and np.all(np.isfinite(fr.frequency_hz))):
            raise InputError("FRF with non-finite values", file=f, field=fr.name)
    if freq.ndim != 1 or freq.size < 2 or np.any(np.diff(freq) <= 0):
        raise InputError("FRF frequencies must increase", file=f, field=frfs[0].name)
    h = np.vstack([fr.values for fr in frfs]) * (kr / kd)
    names = [re.sub(r"\W+", "_", fr.name).strip("_") or f"response{i + 1}"
             for i, fr in enumerate(frfs)] if len(frfs) > 1 else [rname]
    if len(set(names + [dname])) != len(names) + 1:
        raise InputError(f"FRF responses {names} and drive {dname!r} need distinct names",
                         file=f, field="frf")
    return {"frequency_hz": freq, "h_real": h.real, "h_imag": h.imag, "responses": names,
            "labels": [fr.label for fr in frfs], "response_quantity": rq, "drive": dname,
            "drive_quantity": dq, "units": frf_units(rq, dq),
            "estimator": str(cmap.frf.get("estimator", ""))}


def prepare_frf_test(test: SourceTest, cmap: ChannelMap) -> Prepared:
    """An FRF-only test: from the map's [frf] dataset names, or the file's UFF FRFs."""
    f = str(test.file)
    frfs = list(test.frfs)
    if not frfs:
        names = {k: str(cmap.frf.get(k, d)) for k, d in
                 (("frequency", "frequency_hz"), ("real", "re"), ("imag", "im"))}
        freq = test.array(names["frequency"], "frf.frequency").astype(float)
        re_, im_ = (test.array(names[k], f"frf.{k}").astype(float) for k in ("real", "imag"))
        if not freq.size == re_.size == im_.size:
            raise InputError(f"ragged FRF arrays in test {test.name!r}", file=f, field="frf")
        frfs = [SourceFrf(test.name, freq, re_ + 1j * im_, str(test.attrs.get("channel", "")))]
    frf = _frf(frfs, cmap, test)
    md = cmap.test_metadata(test.name, test.file, test.attrs, test.metadata)
    fmax = float(frf["frequency_hz"][-1])
    md.update(source_test=test.name, channel_map=cmap.source, record="frf",
              drive_channels=[frf["drive"]], response_channels=list(frf["responses"]))
    md.pop("frequency_hz", None)
    chans = [(_spec(r, frf["response_quantity"], SI_UNITS[frf["response_quantity"]]), np.empty(0))
             for r in frf["responses"]]
    chans.append((_spec(frf["drive"], frf["drive_quantity"], SI_UNITS[frf["drive_quantity"]]),
                  np.empty(0)))
    return Prepared(safe_name(test.name), test.file, np.empty(0), 2.0 * fmax, chans, md, frf)


def _write_frf(frf: dict[str, Any]) -> Any:
    def write(f: h5py.File) -> None:
        g = f["entry/processed"].create_group(FRF_GROUP)
        g.attrs["NX_class"] = "NXprocess"
        for k in ("frequency_hz", "h_real", "h_imag"):
            ds = g.create_dataset(k, data=np.asarray(frf[k], dtype=float))
            ds.attrs["units"] = "Hz" if k == "frequency_hz" else frf["units"]
        for k in ("response_quantity", "drive", "drive_quantity", "units", "estimator"):
            g.attrs[k] = frf[k]
        g.attrs["responses"] = list(frf["responses"])
        g.attrs["labels"] = list(frf["labels"])
    return write


def prepare_files(files: list[str | Path], cmap: ChannelMap) -> tuple[list[Checked], ImportResult]:
    """Read and check every test of ``files`` (nothing is written): the checked tests,
    and a result listing the tests the map passes over."""
    res = ImportResult()
    prepared: list[Checked] = []
    for p in expand(files, cmap):
        fmt = _format(p, cmap)
        patterns = cmap.include + cmap.frf_tests if (cmap.include or cmap.frf_tests) else []
        tests = read_tests(p, fmt, patterns, cmap.time)
        if not tests:
            raise InputError(f"no test in the file matches {patterns}", file=str(p), field="tests")
        for t in tests:
            if cmap.is_frf(t.name) or (t.frfs and not t.names()):
                how = prepare_frf_test
            elif cmap.selects(t.name):
                how = prepare_record
            else:
                how = None
            if how is not None:
                pr = how(t, cmap)                        # every check, then drop the samples
                prepared.append(Checked(pr.name, pr.file, lambda h=how, t=t: h(t, cmap)))
                del pr
            else:
                res.skipped.append({"file": str(p), "test": t.name,
                                    "reason": "not selected by the map's [tests]"})
    seen: dict[str, Path] = {}
    for pr in prepared:
        if pr.name in seen:
            raise InputError(f"two tests make the run name {pr.name!r} ({seen[pr.name]} and "
                             f"{pr.file}); import them separately", file=str(pr.file))
        seen[pr.name] = pr.file
    return prepared, res


def write_prepared(prepared: list[Checked], res: ImportResult, data_dir: str | Path,
                   catalog: Any = None) -> ImportResult:
    """Write checked tests, one run file each; on any failure none of them stays."""
    for pr in prepared:
        final = layout.run_path(data_dir, pr.name)
        if final.exists():
            raise InputError("a run file with this name already exists", file=str(final))
        if catalog is not None:
            catalog.check_free(pr.name, final)
    try:
        for checked in prepared:
            pr = checked.read()
            res.runs.append(store_channels(pr.file, pr.time, pr.sample_rate_hz, pr.channels,
                                           pr.metadata, data_dir, name=pr.name,
                                           extra=_write_frf(pr.frf) if pr.frf else None))
    except BaseException:
        for written in res.runs:
            written.unlink(missing_ok=True)
        raise
    if catalog is not None:
        for path in res.runs:
            catalog.add(path)
    return res


def import_files(files: list[str | Path], cmap: ChannelMap, data_dir: str | Path,
                 catalog: Any = None) -> ImportResult:
    """Import ``files`` (module doc); returns the run files written and what was skipped."""
    prepared, res = prepare_files(files, cmap)
    return write_prepared(prepared, res, data_dir, catalog)


@dataclass
class ImportedFrf:
    """An FRF stored by :func:`import_files`: H[s, k] = response s / drive at line k."""

    frequency_hz: np.ndarray
    h: np.ndarray
    responses: list[str]
    response_quantity: str
    drive: str
    drive_quantity: str
    units: str
    estimator: str = ""
    path: str | None = None


def read_frf(path: str | Path) -> ImportedFrf:
    """The FRF stored in a run file's ``/entry/processed/frf`` (InputError if none)."""
    with open_run(path) as rf:
        arrays, attrs = rf.processed(FRF_GROUP)
    return ImportedFrf(np.asarray(arrays["frequency_hz"], float),
                       np.asarray(arrays["h_real"]) + 1j * np.asarray(arrays["h_imag"]),
                       [str(r) for r in attrs["responses"]], str(attrs["response_quantity"]),
                       str(attrs["drive"]), str(attrs["drive_quantity"]), str(attrs["units"]),
                       str(attrs.get("estimator", "")), str(path))
