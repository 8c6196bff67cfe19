"""Parse and validate the CSV import format of design.md.

``# key: value`` lines before the header carry metadata (known keys are numbers);
the header names at least ``time_s``, ``displacement_m``, ``force_N``: the suffix
after the last underscore is the unit, and a required column in another unit
(``displacement_mm``, ``time_ms``) is rejected, never converted. Data rows are parsed
by :func:`numpy.loadtxt` in one pass; only when that fails does a line-by-line scan
find the offending line and column. Every error is an :class:`InputError` naming
the file, line and column.

Uniform sampling is required (the pipelines assume it): with ``dt`` the mean step
``(t[-1] - t[0]) / (n - 1)``, every step must lie within ``STEP_TOLERANCE`` (25 %)
of ``dt`` and every time stamp within ``GRID_TOLERANCE`` (half a step) of the grid
``t[0] + k dt``. A ``sample_rate_hz`` in the metadata must match ``1/dt`` within
``RATE_TOLERANCE`` (1 %), which leaves room for time stamps printed with few digits.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.errors import InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage.run import Run

REQUIRED = ("time_s", "displacement_m", "force_N")
KNOWN_KEYS = ("frequency_hz", "sample_rate_hz", "torque_nm", "excitation_vpp", "normal_force_n")
_POSITIVE = ("frequency_hz", "sample_rate_hz")
STEP_TOLERANCE = 0.25
GRID_TOLERANCE = 0.5
RATE_TOLERANCE = 0.01
_ROW_RE = re.compile(r"row (\d+)")


@dataclass
class ParsedCSV:
    """A validated CSV run: header names, values (n_rows, n_columns), metadata."""

    path: Path
    columns: list[str]
    values: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)
    sample_rate_hz: float = 0.0
    header_line: int = 0

    def column(self, name: str) -> np.ndarray:
        """Values of the header column ``name`` (case-insensitive)."""
        low = [c.lower() for c in self.columns]
        return self.values[:, low.index(name.lower())]

    def specs(self) -> list[tuple[ChannelSpec, np.ndarray]]:
        """Channel specs and samples of the import format's columns: ``displacement``
        (m), ``force`` (N) and each further column with quantity ``unknown`` and no unit
        (a column name is not a unit: give a channel map to name quantities)."""
        out = []
        for key, name, quantity, unit in (("displacement_m", "displacement", "displacement", "m"),
                                          ("force_n", "force", "force", "N")):
            out.append((_imported_spec(name, quantity, unit), self.column(key)))
        for col in self.columns:
            if col.lower() not in ("time_s", "displacement_m", "force_n"):
                out.append((_imported_spec(col, "unknown", ""), self.column(col)))
        return out

    def to_channels(self, channels: list[str] | None = None) -> Any:
        """The CSV as a :class:`labjoint.storage.channels.ChannelRecord` (unstored)."""
        from labjoint.storage.channels import make_record
        from labjoint.storage.roles import channel_roles

        specs = dict((s.name, (s, v)) for s, v in self.specs())
        run = self.to_run()
        names = list(specs) if channels is None else list(channels)
        for n in names:
            if n not in specs:
                raise InputError(f"no channel {n!r}; channels: {list(specs)}",
                                 file=str(self.path), field=n)
        md = dict(run.metadata)
        md["channel_quantities"] = {n: s.quantity for n, (s, _) in specs.items()}
        roles = channel_roles(md, list(specs))
        md.update(drive_channels=list(roles.drives), response_channels=list(roles.responses))
        return make_record(run.name, run.time, self.sample_rate_hz, md,
                           [specs[n][0] for n in names], {n: specs[n][1] for n in names},
                           roles, str(self.path))

    def to_run(self) -> Run:
        """The CSV as a :class:`Run` without storing it (channels named as an imported
        run file's: ``displacement``, ``force`` and the extra columns; ``path`` the CSV)."""
        chans = {"displacement": self.column("displacement_m"), "force": self.column("force_N")}
        for c in self.columns:
            if c.lower() not in ("time_s", "displacement_m", "force_n"):
                chans[c] = self.column(c)
        md = dict(self.metadata)
        md.update(sample_rate_hz=self.sample_rate_hz, source="imported",
                  source_file=str(self.path), displacement_channels=["displacement"],
                  joint_force_channel="force")
        return Run(name=self.path.stem, time=self.column("time_s"),
                   displacement=chans["displacement"], force=chans["force"],
                   metadata=md, channels=chans, path=str(self.path))


def _imported_spec(name: str, quantity: str, unit: str) -> ChannelSpec:
    return ChannelSpec(name=name, sensor="imported", quantity=quantity, unit=unit,
                       sensitivity=1.0, range_v=math.inf, coupling="DC")


def unit_of(column: str) -> str:
    """The unit suffix of a column name (``accel_g`` -> ``g``), or ""."""
    return column.rsplit("_", 1)[1] if "_" in column else ""


def parse_csv(path: str | Path) -> ParsedCSV:
    """Read and validate ``path``; raise InputError naming file, line and column."""
    p = Path(path)
    f = str(p)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read file: {exc.strerror}", file=f, line=1, column=REQUIRED[0]) from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise InputError("not UTF-8 text", file=f, line=line, column=REQUIRED[0]) from None
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")

    metadata: dict[str, Any] = {}
    meta_lines: dict[str, int] = {}
    pos, lineno, header = 0, 0, None
    while pos < len(text):
        end = text.find("\n", pos)
        end = len(text) if end < 0 else end
        line, lineno, pos = text[pos:end], lineno + 1, end + 1
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            _meta_line(s[1:], metadata, meta_lines, f, lineno)
            continue
        header = line
        break
    if header is None:
        raise InputError("empty file: no header row with " + ", ".join(REQUIRED),
                         file=f, line=lineno + 1, column=REQUIRED[0])
    columns = _header(header, f, lineno)
    header_line = lineno
    values = _values(text[pos:] if pos < len(text) else "", columns, f, header_line)
    fs = _check_time(values, columns, metadata, meta_lines, f, header_line)
    drive = metadata.get("frequency_hz")
    if drive is not None and drive >= fs / 2:
        raise InputError(f"frequency_hz {drive:g} Hz is at or above the Nyquist frequency "
                         f"{fs / 2:g} Hz of the {fs:g} Hz sampling: the drive cannot be "
                         "resolved (check the units, or the time column)",
                         file=f, line=meta_lines["frequency_hz"], column="frequency_hz")
    return ParsedCSV(p, columns, values, metadata, fs, header_line)


def _meta_line(body: str, md: dict, lines: dict, f: str, lineno: int) -> None:
    key, sep, value = body.partition(":")
    key, value = key.strip(), value.strip()
    if not sep:
        other = body.partition("=")[0].strip()
        if other in KNOWN_KEYS and "=" in body:      # looks like metadata: never drop it silently
            raise InputError(f"metadata is written '# {other}: value', not with '='",
                             file=f, line=lineno, column=other)
        return  # a plain comment
    if not key:
        return
    if key in md:
        raise InputError(f"metadata key {key!r} given twice (line {lines[key]})",
                         file=f, line=lineno, column=key)
    if key in KNOWN_KEYS:
        try:
            x = float(value)
        except ValueError:
            x = math.nan
        if not math.isfinite(x) or "_" in value or (key in _POSITIVE and x <= 0):
            raise InputError(f"metadata {key} must be a finite{' positive' if key in _POSITIVE else ''} "
                             f"number, got {value!r}", file=f, line=lineno, column=key)
        md[key] = x
    else:
        md[key] = value
    lines[key] = lineno


def _header(line: str, f: str, lineno: int) -> list[str]:
    cols = [c.strip().strip('"').strip() for c in next(csv.reader([line]))]
    for i, c in enumerate(cols):
        if not c:
            raise InputError(f"header column {i + 1} has no name", file=f, line=lineno, column=f"#{i + 1}")
        if not c.replace("_", "").isalnum():
            raise InputError(f"column name {c!r} must be letters, digits and '_'",
                             file=f, line=lineno, column=c)
    low = [c.lower() for c in cols]
    for c in cols:
        if low.count(c.lower()) > 1:
            raise InputError(f"column {c!r} appears twice", file=f, line=lineno, column=c)
    for req in REQUIRED:
        if req.lower() in low:
            continue
        quantity = req.rsplit("_", 1)[0]
        wrong = [c for c in cols if c.lower().startswith(quantity + "_")]
        if wrong:
            raise InputError(f"wrong units header {wrong[0]!r}: expected {req!r} "
                             f"(SI, unit '{unit_of(req)}'); values are not converted",
                             file=f, line=lineno, column=wrong[0])
        raise InputError(f"missing column {req!r} (header needs {', '.join(REQUIRED)})",
                         file=f, line=lineno, column=req)
    for c in cols:
        if c.lower() in ("time", "displacement", "force"):
            raise InputError(f"column {c!r} clashes with a stored channel name",
                             file=f, line=lineno, column=c)
    return cols


def _values(body: str, columns: list[str], f: str, header_line: int) -> np.ndarray:
    body = body.rstrip(" \t\n")
    if not body:
        raise InputError("no data rows after the header", file=f, line=header_line + 1,
                         column=columns[0])
    n_lines = body.count("\n") + 1
    try:
        arr = np.loadtxt(io.StringIO(body), delimiter=",", dtype=np.float64, ndmin=2,
                         comments=None)
    except ValueError as exc:
        _scan(body, columns, f, header_line)
        m = _ROW_RE.search(str(exc))
        line = header_line + 1 + (int(m.group(1)) if m else 0)
        raise InputError(f"cannot parse data: {exc}", file=f, line=line, column=columns[0]) from None
    if arr.shape != (n_lines, len(columns)):
        _scan(body, columns, f, header_line)
        raise InputError(f"expected {n_lines} rows of {len(columns)} values, got {arr.shape}",
                         file=f, line=header_line + 1, column=columns[0])
    bad = ~np.isfinite(arr)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise InputError(f"value {arr[r, c]} is not a finite number", file=f,
                         line=header_line + 1 + int(r), column=columns[int(c)])
    return arr


def _scan(body: str, columns: list[str], f: str, header_line: int) -> None:
    """Slow path: find and report the first bad line/cell of ``body``."""
    for i, line in enumerate(body.split("\n")):
        lineno = header_line + 1 + i
        if not line.strip():
            raise InputError("empty line inside the data", file=f, line=lineno, column=columns[0])
        cells = line.split(",")
        if len(cells) != len(columns):
            col = columns[len(cells)] if len(cells) < len(columns) else f"#{len(cells)}"
            raise InputError(f"expected {len(columns)} values, got {len(cells)}",
                             file=f, line=lineno, column=col)
        for name, cell in zip(columns, cells):
            s = cell.strip()
            try:
                if not s or "_" in s:
                    raise ValueError
                float(s)
            except ValueError:
                raise InputError(f"not a number: {cell!r}", file=f, line=lineno, column=name) from None


def _check_time(values: np.ndarray, columns: list[str], md: dict, meta_lines: dict,
                f: str, header_line: int) -> float:
    tcol = [c.lower() for c in columns].index("time_s")
    tname = columns[tcol]
    t = values[:, tcol]
    first = header_line + 1
    if len(t) < 2:
        raise InputError("need at least 2 data rows to know the sample rate", file=f,
                         line=first, column=tname)
    d = np.diff(t)
    nonpos = np.flatnonzero(d <= 0)
    if nonpos.size:
        k = int(nonpos[0]) + 1
        raise InputError(f"time does not increase: {float(t[k])!r} s after {float(t[k - 1])!r} s",
                         file=f, line=first + k, column=tname)
    dt = (t[-1] - t[0]) / (len(t) - 1)
    off = np.flatnonzero(np.abs(d - dt) > STEP_TOLERANCE * dt)
    if off.size:
        k = int(off[0]) + 1
        raise InputError(f"irregular sampling: step {d[k - 1]:.6g} s differs from the mean "
                         f"step {dt:.6g} s by more than {STEP_TOLERANCE:.0%}",
                         file=f, line=first + k, column=tname)
    resid = t - (t[0] + dt * np.arange(len(t)))
    off = np.flatnonzero(np.abs(resid) > GRID_TOLERANCE * dt)
    if off.size:
        k = int(off[0])
        raise InputError(f"irregular sampling: time {t[k]:.9g} s is {resid[k] / dt:+.2f} steps "
                         "off the uniform grid", file=f, line=first + k, column=tname)
    fs = md.get("sample_rate_hz")
    if fs is None:
        return float(1.0 / dt)
    if abs(fs * dt - 1.0) > RATE_TOLERANCE:
        raise InputError(f"sample_rate_hz {fs:g} disagrees with the time column "
                         f"(mean step {dt:.6g} s = {1 / dt:.6g} Hz)",
                         file=f, line=meta_lines["sample_rate_hz"], column="sample_rate_hz")
    return float(fs)
