"""`labjoint structure measured RUNS... --out FRF.json` and `labjoint structure ema FRF.json`:
FRF sets from step-sine runs, and their modal parameters (LSCF/LSFD and half-power)."""

from __future__ import annotations

import argparse
from typing import Any

from labjoint.cli.output import emit_json, table
from labjoint.errors import InputError


def add_measured_parsers(sub: Any) -> None:
    """The ``measured`` and ``ema`` actions of ``labjoint structure``."""
    h = "FRF set (force, drive voltage, response harmonics per step) from step_sine runs"
    q = sub.add_parser("measured", help=h, description=h)
    q.add_argument("runs", nargs="+", metavar="RUN", help="step_sine run files (HDF5)")
    q.add_argument("--out", required=True, metavar="FRF.json", help="where to write the FRF set")
    q.add_argument("--sensors", default=None, help="response channels, comma-separated (default: accelerometers)")
    q.add_argument("--harmonics", type=int, default=3, help="response harmonics h f, h = 1..H (default 3)")
    q.add_argument("--segments", type=int, default=8, help="pieces of whole cycles per step (default 8)")
    q.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON object")
    h = "natural frequency and damping ratio per sweep of an FRF set (LSCF/LSFD and half-power)"
    q = sub.add_parser("ema", help=h, description=h)
    q.add_argument("frf", metavar="FRF.json")
    q.add_argument("--sensor", default=None, help="sensor for the half-power method (default: largest)")
    q.add_argument("--order", type=int, default=8, help="highest LSCF model order (default 8)")
    q.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON object")


def run_measured(args: argparse.Namespace) -> int:
    from labjoint.signal.frf_steps import frfset_from_runs

    if args.harmonics < 1:
        raise InputError(f"must be >= 1, got {args.harmonics}", field="--harmonics")
    sensors = [x.strip() for x in args.sensors.split(",") if x.strip()] if args.sensors else None
    s = frfset_from_runs(args.runs, sensors=sensors, harmonics=args.harmonics, segments=args.segments)
    s.save(args.out)
    groups = [{"level_n": lv, "direction": d, "steps": int(i.size),
               "frequencies_hz": [float(s.frequencies_hz[i].min()), float(s.frequencies_hz[i].max())]}
              for (lv, d), i in s.groups()]
    res = {"out": str(args.out), "steps": len(s), "sensors": list(s.sensors), "harmonics": s.harmonics,
           "drive_voltage": s.drive_v is not None, "groups": groups,
           "unconverged": s.metadata.get("unconverged", [])}
    if getattr(args, "json", False):
        emit_json(res)
        return 0
    print(f"{len(s)} steps, sensors {', '.join(s.sensors)} -> {args.out}")
    print(table(["level N", "direction", "steps", "from Hz", "to Hz"],
                [(g["level_n"], g["direction"], g["steps"], *g["frequencies_hz"]) for g in groups]))
    return 0


def run_ema(args: argparse.Namespace) -> int:
    from labjoint.identify.modal import modal_parameters
    from labjoint.signal.frfset import FrfSet

    if args.order < 2:
        raise InputError(f"must be >= 2, got {args.order}", field="--order")
    groups = modal_parameters(FrfSet.load(args.frf), sensor=args.sensor, order=args.order)
    if getattr(args, "json", False):
        emit_json({"frf": str(args.frf), "groups": groups})
        return 0
    rows = [(g["level_n"], g["direction"], g["lscf"]["natural_frequency_hz"], g["lscf"]["damping_ratio"],
             g["half_power"]["natural_frequency_hz"], g["half_power"]["damping_ratio"]) for g in groups]
    print(table(["level N", "dir", "LSCF Hz", "LSCF zeta", "half-power Hz", "half-power zeta"], rows))
    return 0
