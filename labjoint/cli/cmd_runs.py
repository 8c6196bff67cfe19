"""`labjoint runs [--torque NM] [--vpp LO:HI] ...`: query the run catalog."""

from __future__ import annotations

import argparse
from pathlib import Path

from labjoint.cli.output import emit_json, table


def _range(text: str) -> tuple[float, float] | float:
    if ":" in text:
        lo, hi = text.split(":", 1)
        return float(lo), float(hi)
    return float(text)


def add_runs_arguments(p: argparse.ArgumentParser, limit: int | None = 100) -> None:
    p.add_argument("--data", "--data-dir", dest="data", default=None,
                   help="data directory (default: the config's data_dir)")
    p.add_argument("--torque", type=_range, default=None, help="torque in Nm, or LO:HI")
    p.add_argument("--vpp", type=_range, default=None, help="excitation in Vpp, or LO:HI")
    p.add_argument("--frequency", type=_range, default=None, help="frequency in Hz, or LO:HI")
    p.add_argument("--status", default=None)
    p.add_argument("--plan", default=None)
    p.add_argument("--limit", type=int, default=limit)


def run(args: argparse.Namespace) -> int:
    from labjoint.config import load_config
    from labjoint.storage.catalog import Catalog

    data = Path(args.data or load_config(args.config).rig.data_dir)
    cat = Catalog(data / "catalog.sqlite")
    recs = cat.query(torque_nm=args.torque, vpp=args.vpp, frequency_hz=args.frequency,
                     status=args.status, plan=args.plan, limit=args.limit)
    rows = [r.to_dict() if hasattr(r, "to_dict") else dict(r.__dict__) for r in recs]
    if args.json:
        emit_json({"runs": rows})
    else:
        print(table(["name", "plan", "f Hz", "Vpp", "Nm", "status", "samples"],
                    [[r.get("name"), r.get("plan"), r.get("frequency_hz"), r.get("excitation_vpp"),
                      r.get("torque_nm"), r.get("status"), r.get("n_samples")] for r in rows]))
    return 0
