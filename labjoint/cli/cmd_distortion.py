"""`labjoint distortion RUN... [--drive CH] [--orders H] [--blocks B] [--json]`: the
harmonics of every channel of a steady-sine record (h/h1 with its standard error from
blocks of whole cycles), or, for a multisine, the best linear approximation and the odd
and even nonlinear distortion against the noise per band."""

from __future__ import annotations

import argparse

from labjoint.cli.output import emit_json, table


def add_distortion_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", nargs="+", metavar="RUN", help="run files (HDF5)")
    p.add_argument("--drive", default=None, help="drive channel (default: the one force, else the one voltage)")
    p.add_argument("--orders", type=int, default=5, help="harmonics 2..H reported (default 5)")
    p.add_argument("--blocks", type=int, default=8, help="blocks of whole cycles for the spread (default 8)")
    p.add_argument("--bands", type=int, default=6, help="multisine: bands of the excited range (default 6)")


def run(args: argparse.Namespace) -> int:
    from labjoint.identify.spectral import distortion_runs

    runs = distortion_runs(args.runs, args)["runs"]
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
