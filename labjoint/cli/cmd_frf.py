"""`labjoint frf RUN... --out FRF.json [--json]` and `labjoint modes RUN...|FRF.json
[--band LO:HI] [--json]`: FRFs of broadband records (H1/H2/Hv, coherence, std; one level
per record) and the modes of any FRF set (LSCF/LSFD with automatic pole selection,
half-power beside), per level."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.cli.output import emit_json, table
from labjoint.errors import InputError


def _frf_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--drive", default=None, help="drive channel (default: the one force, else the one voltage)")
    p.add_argument("--responses", default=None, help="response channels, comma-separated (default: all)")
    p.add_argument("--estimator", choices=["H1", "H2", "Hv"], default="H1")
    p.add_argument("--method", choices=["auto", "welch", "periodic", "burst", "block"], default="auto",
                   help="auto: from the excitation (whole periods of a multisine; one unwindowed block "
                        "per burst of a burst record, its free decay included; Welch over the active "
                        "drive of a steady random record; one block for a sweep)")
    p.add_argument("--nperseg", type=int, default=None, help="Welch segment length (samples)")
    p.add_argument("--overlap", type=float, default=None, help="Welch overlap, 0..1")
    p.add_argument("--window", default="hann", help="Welch window (scipy name)")


def add_frf_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", nargs="+", metavar="RUN", help="run files (HDF5) of broadband records")
    p.add_argument("--out", required=True, metavar="FRF.json", help="where to write the FRF set")
    p.add_argument("--band", default="drive", metavar="LO:HI|drive|all",
                   help="lines kept (default: where the drive carries power)")
    _frf_options(p)


def add_modes_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("inputs", nargs="+", metavar="RUN|FRF.json", help="run files or FRF sets")
    p.add_argument("--band", default=None, metavar="LO:HI", help="frequency band in Hz")
    p.add_argument("--order", type=int, default=None, help="highest LSCF model order (default: from the lines)")
    _frf_options(p)


def frf_levels(paths: list[str], args: argparse.Namespace) -> list[Any]:
    """One FrfSet level per record."""
    from labjoint.cli.records import level_of, load
    from labjoint.signal.frf_levels import frfset_from_arrays

    resp = [x.strip() for x in args.responses.split(",") if x.strip()] if args.responses else None
    out = []
    for path in paths:
        rec = load(path)
        d = rec.drive(args.drive)
        names = rec.responses(resp)
        try:
            s = frfset_from_arrays(rec.channels[d][2], rec.channels[d][0],
                                   {n: (rec.channels[n][0], rec.channels[n][2]) for n in names},
                                   rec.fs, level=level_of(rec), run=rec.name, estimator=args.estimator,
                                   source=path, nperseg=args.nperseg, overlap=args.overlap,
                                   window=args.window, method=args.method,
                                   band=_frf_band(getattr(args, "frf_band", "drive")))
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
        s.metadata.update(drive=d, run=rec.name, path=path)
        out.append(s)
    return out


def _summary(s: Any) -> dict[str, Any]:
    md = s.metadata
    return {"run": md.get("run"), "level": float(s.level_n[0]), "level_units": s.level_units,
            "drive": md.get("drive"), "drive_quantity": s.drive_quantity, "quantity": s.quantity,
            "units": s.units, "estimator": s.estimator, "sensors": list(s.sensors), "lines": len(s),
            "frequency_hz": [float(s.frequencies_hz[0]), float(s.frequencies_hz[-1])],
            "band_hz": md.get("band_hz"), "averages": md.get("averages"), "method": md.get("method"),
            "median_coherence": None if s.coherence is None else float(np.median(s.coherence))}


def run_frf(args: argparse.Namespace) -> int:
    from labjoint.signal.frfset import concat

    args.frf_band = args.band
    levels = frf_levels(args.runs, args)
    merged = concat(levels)
    merged.metadata.update(levels=[{k: v for k, v in s.metadata.items()} for s in levels])
    merged.save(args.out)
    res = {"path": str(args.out), "format": "labjoint.frfset/1", "levels": [_summary(s) for s in levels]}
    if getattr(args, "json", False):
        emit_json(res)
        return 0
    print(f"{len(levels)} level(s) -> {args.out}")
    print(table(["run", "level", "units", "lines", "averages", "median coh"],
                [(lv["run"], f"{lv['level']:.4g} {lv['level_units']}", lv["units"], lv["lines"],
                  lv["averages"], lv["median_coherence"]) for lv in res["levels"]]))
    return 0


def _frf_band(text: str) -> tuple[float, float] | str | None:
    return {"drive": "drive", "all": None}.get(text) or _band(text, "--band")


def _band(text: str | None, name: str = "--band") -> tuple[float, float] | None:
    if not text:
        return None
    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        raise InputError(f"must be LO:HI in Hz, got {text!r}", field=name) from None
    if not 0 <= lo < hi:
        raise InputError(f"must be 0 <= LO < HI, got {text!r}", field=name)
    return lo, hi


def _sets(inputs: list[str], args: argparse.Namespace) -> list[Any]:
    from labjoint.signal.frfset import FrfSet

    sets = []
    for p in inputs:
        if Path(p).suffix.lower() == ".json":
            s = FrfSet.load(p)
            for (lv, d), idx in s.groups():
                sub = s.subset(idx)
                sub.metadata.update(path=p, direction=d)
                runs = {r for r in sub.runs}
                match = [m for m in s.metadata.get("levels", []) if m.get("run") in runs]
                if match:
                    sub.metadata.update(match[0])
                sub.metadata["path"] = p
                sets.append(sub)
        else:
            sets.extend(frf_levels([p], args))
    return sets


def run_modes(args: argparse.Namespace) -> int:
    from labjoint.identify.modes import find_modes

    band = _band(args.band)
    levels = []
    for s in _sets(args.inputs, args):
        h = s.response[:, :, 0].T / s.force[None, :]
        b = band or (tuple(s.metadata["band_hz"]) if s.metadata.get("band_hz") else None)
        try:
            modes = find_modes(s.frequencies_hz, h, s.quantity, s.sensors, b, args.order)
        except InputError as exc:
            raise InputError(f"{s.metadata.get('path', '')}: {exc}") from None
        levels.append({"run": s.metadata.get("run"), "level": float(s.level_n[0]),
                       "level_units": s.level_units, "direction": str(s.direction[0]),
                       "units": s.units, "band_hz": list(b) if b else None, "modes": modes})
    levels.sort(key=lambda lv: (lv["level"], lv["direction"]))
    if getattr(args, "json", False):
        emit_json({"levels": levels})
        return 0
    rows = [(lv["run"] or "", f"{lv['level']:.4g} {lv['level_units']}", i + 1, m["frequency_hz"],
             m["damping_ratio"], m["half_power"]["frequency_hz"], m["half_power"]["damping_ratio"])
            for lv in levels for i, m in enumerate(lv["modes"])]
    print(table(["run", "level", "mode", "LSCF Hz", "LSCF zeta", "half-power Hz", "half-power zeta"], rows))
    return 0
