"""`labjoint export RUN... --uff OUT`: runs as universal files (UFF 58: time records and
the receptance FRF with its coherence) for other modal tools."""

from __future__ import annotations

import argparse
from pathlib import Path

from labjoint.cli.output import emit_json


def add_export_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", nargs="+", metavar="RUN", help="HDF5 run files or CSV records")
    p.add_argument("--uff", required=True, metavar="OUT",
                   help="a .uff/.unv file (one run) or a directory (one RUN.uff per run)")
    p.add_argument("--no-frf", action="store_true", help="time records only")


def run(args: argparse.Namespace) -> int:
    from labjoint.errors import InputError
    from labjoint.signal.uff_export import export_uff
    from labjoint.storage import read_any

    out = Path(args.uff)
    to_dir = out.is_dir() or out.suffix.lower() not in (".uff", ".unv")
    if not to_dir and len(args.runs) > 1:
        raise InputError("several runs go to a directory, not one file", field="--uff")
    if to_dir and not out.is_dir():
        raise InputError("no such directory (or name a .uff file)", file=str(out), field="--uff")
    written = []
    for r in args.runs:
        run_ = read_any(r)
        target = out / f"{run_.name}.uff" if to_dir else out
        res = export_uff(run_, target, frf=not args.no_frf)
        written.append({"run": run_.name, **res})
    if args.json:
        emit_json({"exported": written})
    else:
        for w in written:
            frf = f", FRF at {w['frf_lines']} lines ({w['frf_method']})" if w["frf_lines"] else ""
            print(f"{w['file']}: {w['datasets']} data-sets, {w['samples']} samples{frf}")
    return 0
