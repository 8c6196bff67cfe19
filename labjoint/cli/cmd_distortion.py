"""`labjoint distortion RUN... [--drive CH] [--orders H] [--blocks B] [--json]`: the
harmonics of every channel of a steady-sine record (h/h1 with its standard error from
blocks of whole cycles), or, for a multisine, the best linear approximation and the odd
and even nonlinear distortion against the noise per band."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from labjoint.cli.output import emit_json, table
from labjoint.errors import InputError


def add_distortion_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", nargs="+", metavar="RUN", help="run files (HDF5)")
    p.add_argument("--drive", default=None, help="drive channel (default: the one force, else the one voltage)")
    p.add_argument("--orders", type=int, default=5, help="harmonics 2..H reported (default 5)")
    p.add_argument("--blocks", type=int, default=8, help="blocks of whole cycles for the spread (default 8)")
    p.add_argument("--bands", type=int, default=6, help="multisine: bands of the excited range (default 6)")


def one(path: str, args: argparse.Namespace) -> dict[str, Any]:
    from labjoint.cli.records import load
    from labjoint.signal import distortion
    from labjoint.signal.excitation import detect_excitation

    rec = load(path)
    d = rec.drive(args.drive)
    u = rec.channels[d][2]
    exc = detect_excitation(u, rec.fs)
    try:
        if exc.kind == "multisine" and exc.period_s:
            n = int(round(exc.period_s * rec.fs))
            chans = {name: {"quantity": q, "units": unit,
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


def run(args: argparse.Namespace) -> int:
    if args.orders < 2 or args.blocks < 2:
        raise InputError("--orders and --blocks must be >= 2", field="--orders")
    runs = [one(p, args) for p in args.runs]
    if getattr(args, "json", False):
        emit_json({"runs": runs})
        return 0
    for r in runs:
        if r["excitation"] == "multisine":
            for name, c in r["channels"].items():
                print(f"{r['run']} {name}: {c['summary']}")
            continue
        rows = [(r["run"], f"{r['frequency_hz']:.4g}", name, c["units"],
                 *[f"{h['ratio']:.4g}±{h['stderr']:.2g}" for h in c["harmonics"][:3]])
                for name, c in r["channels"].items()]
        print(table(["run", "Hz", "channel", "units", "h2/h1", "h3/h1", "h4/h1"], rows))
    return 0
