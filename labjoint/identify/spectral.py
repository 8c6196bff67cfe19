"""FRFs, modes and the distortion report of run files: the pipelines behind `labjoint frf`,
`labjoint modes` and `labjoint distortion` and their REST twins (``/spectra/...``), written
once so both answer the same JSON (design.md, CLI).

Options are any object with the attributes of :class:`SpectralOptions` (the CLI passes
its argparse namespace). Bad input raises InputError naming the file and the channel.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.errors import InputError


@dataclass
class SpectralOptions:
    """What `labjoint frf`, `modes` and `distortion` take on their command lines."""

    drive: str | None = None
    responses: str | None = None          # comma-separated channel names
    estimator: str = "H1"
    method: str = "auto"
    burst: str = "block"                  # a burst record: "block" (Testlab's H1) or "driven"
    nperseg: int | None = None
    overlap: float | None = None
    window: str = "hann"
    frf_band: str = "drive"               # frf: LO:HI, "drive" or "all"
    band: str | None = None               # modes: LO:HI
    order: int | None = None
    orders: int = 5
    blocks: int = 8
    bands: int = 6


def frf_levels(paths: list[str], args: Any, progress: Any = None) -> list[Any]:
    """One FrfSet level per record; ``progress(fraction, message)`` before each."""
    from labjoint.identify.records import level_of, load, streamed
    from labjoint.signal.burst import check_burst
    from labjoint.signal.frf_levels import frfset_from_arrays

    check_burst(getattr(args, "burst", "block"))      # before any record is read
    resp = [x.strip() for x in args.responses.split(",") if x.strip()] if args.responses else None
    out = []
    for i, path in enumerate(paths):
        if progress is not None:
            progress(i / len(paths), f"FRF of {Path(path).stem}")
        with streamed(path) as st:
            if st is not None:
                out.append(streamed_level(st, resp, args))
                continue
        rec = load(path)
        d = rec.drive(args.drive)
        names = rec.responses(resp)
        try:
            s = frfset_from_arrays(rec.channels[d][2], rec.channels[d][0],
                                   {n: (rec.channels[n][0], rec.channels[n][2]) for n in names},
                                   rec.fs, level=level_of(rec), run=rec.name, estimator=args.estimator,
                                   source=path, nperseg=args.nperseg, overlap=args.overlap,
                                   window=args.window, method=args.method,
                                   burst=getattr(args, "burst", "block"),
                                   band=frf_band(getattr(args, "frf_band", "drive")))
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
        s.metadata.update(drive=d, run=rec.name, path=path)
        out.append(s)
    return out


def streamed_level(st: Any, resp: list[str] | None, args: Any) -> Any:
    """One level of a record too long to load, read in blocks (Welch sums streamed)."""
    from labjoint.identify.records import level_of
    from labjoint.signal.broadband_stream import estimate_streamed
    from labjoint.signal.frf_levels import check_channels, frfset_from_result

    d = st.drive(args.drive)
    names = st.responses(resp)
    quantities = {n: st.channels[n][0] for n in names}
    check_channels(st.channels[d][0], quantities, st.path)
    try:
        r = estimate_streamed(lambda a, b: (st.read([d], a, b)[0], st.read(names, a, b)),
                              lambda a, b: st.read([d], a, b)[0], st.n, st.fs, len(names),
                              estimator=args.estimator, nperseg=args.nperseg, overlap=args.overlap,
                              window=args.window, method=args.method,
                              burst=getattr(args, "burst", "block"))
        s = frfset_from_result(r, st.channels[d][0], quantities,
                               level=level_of(st), run=st.name, estimator=args.estimator,
                               source=st.path, band=frf_band(getattr(args, "frf_band", "drive")))
    except InputError as exc:
        raise InputError(f"{st.path}: {exc}") from None
    s.metadata.update(drive=d, run=st.name, path=st.path)
    return s


def summary(s: Any) -> dict[str, Any]:
    md = s.metadata
    return {"run": md.get("run"), "level": float(s.level_n[0]), "level_units": s.level_units,
            "drive": md.get("drive"), "drive_quantity": s.drive_quantity, "quantity": s.quantity,
            "units": s.units, "estimator": s.estimator, "alternatives": sorted(s.alternatives),
            "sensors": list(s.sensors), "lines": len(s),
            "frequency_hz": [float(s.frequencies_hz[0]), float(s.frequencies_hz[-1])],
            "band_hz": md.get("band_hz"), "averages": md.get("averages"), "method": md.get("method"),
            "median_coherence": None if s.coherence is None else float(np.median(s.coherence))}


def frf_band(text: str) -> tuple[float, float] | str | None:
    if text in ("drive", "all"):
        return "drive" if text == "drive" else None
    return parse_band(text, "--band")


def parse_band(text: str | None, name: str = "--band") -> tuple[float, float] | None:
    if not text:
        return None
    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        raise InputError(f"must be LO:HI in Hz, got {text!r}", field=name) from None
    if not 0 <= lo < hi:
        raise InputError(f"must be 0 <= LO < HI, got {text!r}", field=name)
    return lo, hi


def frf_sets(inputs: list[str], args: Any) -> list[Any]:
    from labjoint.signal.frfset import FrfSet

    sets = []
    for p in inputs:
        if Path(p).suffix.lower() == ".json":
            s = FrfSet.load(p)
            if s.estimator != "stepped_sine" and s.runs:   # broadband: one level per record
                parts = [(str(s.direction[0]), np.flatnonzero(np.asarray(s.runs) == r))
                         for r in dict.fromkeys(s.runs)]
            else:
                parts = [(d, idx) for (_, d), idx in s.groups()]
            for d, idx in parts:
                sub = s.subset(idx)
                sub.metadata.update(path=p, direction=d)
                runs = {r for r in sub.runs}
                match = [m for m in s.metadata.get("levels", []) if m.get("run") in runs]
                if match:
                    sub.metadata.update(match[0])
                sub.metadata["path"] = p
                sets.append(sub)
        else:
            imported = imported_frf(p)
            sets.extend([imported] if imported is not None else frf_levels([p], args))
    return sets


def imported_frf(path: str) -> Any:
    """An FRF a lab exported (imported into a run file's processed/frf) as one level, or
    None when the run file holds none. Its level is unknown: reported as null."""
    from labjoint.errors import InputError as _IE
    from labjoint.signal.frfset import DRIVES, QUANTITIES, FrfSet
    from labjoint.storage.importers import read_frf

    if Path(path).suffix.lower() not in (".h5", ".hdf5"):
        return None
    try:
        r = read_frf(path)
    except (_IE, KeyError, OSError):
        return None
    if r.response_quantity not in QUANTITIES or r.drive_quantity not in DRIVES:
        raise InputError(f"{path}: an FRF of {r.response_quantity} over {r.drive_quantity} has no modes "
                         "labjoint can fit", field="frf")
    keep = r.frequency_hz > 0
    f, h = r.frequency_hz[keep], r.h[:, keep]
    n = f.size
    est = r.estimator.split()[0] if r.estimator.split() and r.estimator.split()[0] in ("H1", "H2", "Hv") \
        else "stepped_sine"
    s = FrfSet(f, np.ones(n), np.full(n, "up"), np.ones(n, complex), tuple(r.responses), h.T[:, :, None],
               np.zeros((n, len(r.responses), 1)), r.response_quantity, None, (), {}, r.drive_quantity, est)
    s.metadata.update(path=path, run=Path(path).stem, imported=True, estimator_text=r.estimator)
    return s


def modes_levels(inputs: list[str], args: Any) -> list[dict[str, Any]]:
    """`labjoint modes --json`'s levels: one per run or FRF level, sorted by level."""
    from labjoint.identify.modes import find_modes

    band = parse_band(getattr(args, "band", None))
    levels = []
    for s in frf_sets(inputs, args):
        h = s.response[:, :, 0].T / s.force[None, :]
        b = band or (tuple(s.metadata["band_hz"]) if s.metadata.get("band_hz") else None)
        try:
            modes = find_modes(s.frequencies_hz, h, s.quantity, s.sensors, b, getattr(args, "order", None))
        except InputError as exc:
            raise InputError(f"{s.metadata.get('path', '')}: {exc}") from None
        levels.append({"run": s.metadata.get("run"),
                       "level": None if s.metadata.get("imported") else float(s.level_n[0]),
                       "level_units": s.level_units, "direction": str(s.direction[0]),
                       "units": s.units, "band_hz": list(b) if b else None, "modes": modes})
    levels.sort(key=lambda lv: (lv["level"] is None, lv["level"] or 0.0, lv["direction"]))
    return levels


def distortion_run(path: str, args: Any) -> dict[str, Any]:
    from labjoint.identify.records import load
    from labjoint.signal import distortion
    from labjoint.signal.excitation import detect_excitation

    rec = load(path)
    d = rec.drive(args.drive)
    u = rec.channels[d][2]
    try:
        exc = detect_excitation(u, rec.fs)
        if exc.kind == "multisine" and exc.period_s:
            n = int(round(exc.period_s * rec.fs))
            chans = {name: {"quantity": q, "units": unit, "harmonics": [],   # no single fundamental
                            **distortion.multisine(u, x, rec.fs, n, bands=args.bands)}
                     for name, (q, unit, x) in rec.channels.items() if name != d}
            worst = max((c for c in chans.values() if c["quantity"] != rec.channels[d][0]),
                        key=lambda c: max([b[k] for b in c["bands"] for k in ("odd_db", "even_db")
                                           if b[k] is not None] or [-np.inf]), default=None)
            return {"run": rec.name, "path": path, "excitation": "multisine", "frequency_hz": None,
                    "period_s": n / rec.fs, "drive": d, "channels": chans,
                    "summary": worst["summary"] if worst else None}
        if exc.kind != "sine":
            raise InputError(f"the drive {d!r} holds {exc.describe()}: the distortion report needs a "
                             "steady sine or a multisine", field=d)
        f0, res = distortion.harmonics({n: c[2] for n, c in rec.channels.items()}, rec.fs, drive=d,
                                       orders=args.orders, blocks=args.blocks,
                                       frequency_hz=None)
    except InputError as exc_:
        raise InputError(f"{path}: {exc_}") from None
    chans = {name: {"quantity": rec.channels[name][0], "units": rec.channels[name][1],
                    "amplitude": res[name][0]["amplitude"],
                    "harmonics": [{k: h[k] for k in ("order", "ratio", "stderr")} for h in res[name][1:]]}
             for name in rec.channels}
    return {"run": rec.name, "path": path, "excitation": "sine", "frequency_hz": f0, "drive": d,
            "channels": chans}


def frf_out(paths: list[str], out: str | Path, args: Any, progress: Any = None) -> dict[str, Any]:
    """FRFs of ``paths`` (one level each) written to ``out`` as one FrfSet JSON (written
    whole or not at all): `labjoint frf --json`'s answer."""
    from labjoint.signal.frfset import concat, writable_path

    writable_path(out)                    # before the FRFs are computed
    levels = frf_levels(paths, args, progress)
    merged = concat(levels)
    merged.metadata.update(levels=[{k: v for k, v in s.metadata.items()} for s in levels])
    merged.save(out)
    return {"path": str(out), "format": "labjoint.frfset/1", "levels": [summary(s) for s in levels]}


def distortion_runs(paths: list[str], args: Any, progress: Any = None) -> dict[str, Any]:
    """`labjoint distortion --json`'s answer."""
    if args.orders < 2 or args.blocks < 2:
        raise InputError("--orders and --blocks must be >= 2", field="--orders")
    out = []
    for i, p in enumerate(paths):
        if progress is not None:
            progress(i / len(paths), f"distortion of {Path(p).stem}")
        out.append(distortion_run(p, args))
    return {"runs": out}
