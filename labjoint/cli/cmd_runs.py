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
    p.add_argument("--has-result", default=None, metavar="VERSION",
                   help="only runs holding a complete result of this pipeline version "
                        "(as `labjoint reprocess` prints it, e.g. analyze-0123abcd...)")
    p.add_argument("--stale", action="store_true",
                   help="only runs holding a result whose pipeline version is not current")


def run(args: argparse.Namespace) -> int:
    from labjoint.config import load_config
    from labjoint.storage.catalog import catalog_for

    cfg = load_config(args.config)
    cat = catalog_for(cfg, Path(args.data or cfg.rig.data_dir))
    filtered = args.has_result is not None or args.stale
    recs = cat.query(torque_nm=args.torque, vpp=args.vpp, frequency_hz=args.frequency,
                     status=args.status, plan=args.plan, limit=None if filtered else args.limit)
    rows = [r.to_dict() if hasattr(r, "to_dict") else dict(r.__dict__) for r in recs]
    _add_results(cat, rows)
    if args.has_result is not None:
        rows = [r for r in rows if any(x["version"] == args.has_result and
                                       x["status"] == "complete" for x in r["results"])]
    if args.stale:
        rows = [r for r in rows if any(x["stale"] for x in r["results"])]
    if filtered and args.limit is not None:
        rows = rows[:args.limit]
    if args.json:
        emit_json({"runs": rows})
    else:
        print(table(["name", "plan", "f Hz", "Vpp", "Nm", "status", "samples", "results"],
                    [[r.get("name"), r.get("plan"), r.get("frequency_hz"), r.get("excitation_vpp"),
                      r.get("torque_nm"), r.get("status"), r.get("n_samples"),
                      _results_cell(r["results"])] for r in rows]))
    return 0


def _add_results(cat: object, rows: list[dict]) -> None:
    """Each row's recorded pipeline results: {pipeline, version, status, stale, ...};
    stale: computed by another version of the pipeline than the current one."""
    from labjoint.batch.pipelines import PIPELINES, pipeline_version
    from labjoint.storage.results import Results

    by_run = Results(cat).for_runs([r["name"] for r in rows])
    for r in rows:
        r["results"] = [{"pipeline": x.pipeline, "options_hash": x.options_hash,
                         "version": x.version, "status": x.status, "computed_at": x.computed_at,
                         "stale": x.pipeline in PIPELINES and x.version != pipeline_version(x.pipeline)}
                        for x in by_run.get(r["name"], [])]


def _results_cell(results: list[dict]) -> str:
    """e.g. ``analyze ok, fit stale, diagnose failed``."""
    if not results:
        return "-"
    return ", ".join(f"{x['pipeline']} " + ("stale" if x["stale"] else
                                             "ok" if x["status"] == "complete" else x["status"])
                     for x in results)
