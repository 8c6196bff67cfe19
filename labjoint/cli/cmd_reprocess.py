"""`labjoint reprocess [QUERY] --pipeline analyze|stickslip|fit|diagnose|ladder [options]
[--scheduler local|none|tcp://HOST:PORT] [--json]`: a pipeline over catalogued runs, on Dask.

QUERY takes the filters of ``labjoint runs`` (no filter: every catalogued run under
``--data-dir``). Runs whose result for the same pipeline, options and pipeline version is
recorded complete are skipped without being opened; see :mod:`labjoint.batch.reprocess`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from labjoint.cli.cmd_runs import add_runs_arguments
from labjoint.cli.output import Progress, emit_json, table, terminal_safe
from labjoint.errors import InputError

PIPELINE_NAMES = ("analyze", "stickslip", "fit", "diagnose", "ladder")
GROUPED = ("fit", "diagnose", "ladder")


def add_reprocess_arguments(p: argparse.ArgumentParser) -> None:
    add_runs_arguments(p, limit=None)
    p.add_argument("--pipeline", required=True, choices=PIPELINE_NAMES)
    p.add_argument("--scheduler", default="local",
                   help="local: a Dask LocalCluster sized to this machine (default); "
                        "tcp://HOST:PORT: a running dask scheduler; none: in this process")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--recompute", action="store_true",
                   help="compute even runs whose result is current")
    p.add_argument("--force", dest="force_sensor", choices=("joint", "reference"),
                   default="joint", help="force sensor of analyze/stickslip (default joint)")
    p.add_argument("--friction", type=float, default=None,
                   help="stickslip: friction coefficient (default: the identified one)")
    p.add_argument("--model", default=None, metavar="EXPR", help="fit/diagnose/ladder: model")
    p.add_argument("--group-by", default=None, metavar="COLUMN",
                   help="fit/diagnose/ladder: one group (one task) per value of this catalog "
                        "column or metadata key, e.g. torque_nm (default: one group)")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--kind", choices=("auto", "sine", "record"), default=None)
    p.add_argument("--factor", type=float, default=None)
    p.add_argument("--alpha", type=float, default=None)
    p.add_argument("--candidates", default=None, metavar="A,B,...")
    p.add_argument("--max-steps", type=int, default=None, help="ladder: at most N effects")
    p.add_argument("--max-displacement", type=float, default=None, metavar="M",
                   help="fit/diagnose/ladder: largest plausible displacement amplitude (m) of a "
                        "steady sine, over the rig config's [plausibility] table (--config)")


def pipeline_options(args: argparse.Namespace, data_dir: Path) -> dict[str, Any]:
    """The pipeline's options from the arguments (:func:`labjoint.batch.options.check_options`)."""
    from labjoint.batch.options import check_options

    given: dict[str, Any] = {"model": args.model, "seed": args.seed, "kind": args.kind,
                             "factor": args.factor, "alpha": args.alpha,
                             "candidates": args.candidates, "max_steps": args.max_steps}
    if args.pipeline in GROUPED:
        from labjoint.cli.limits import config_table

        given.update(plausibility=config_table(args) or None, max_displacement=args.max_displacement)
    elif args.max_displacement is not None:
        given["max_displacement"] = args.max_displacement
    if args.pipeline in ("analyze", "stickslip"):
        given["force"] = args.force_sensor
    if args.pipeline == "stickslip":
        given["friction"] = args.friction
    elif args.friction is not None:
        given["friction"] = args.friction
    if args.group_by is not None and args.pipeline not in GROUPED:
        raise InputError(f"applies to fit, diagnose and ladder, not {args.pipeline}",
                         field="--group-by")
    try:
        return check_options(args.pipeline, given, data_dir)
    except InputError as exc:
        raise InputError(exc.message, field="--" + str(exc.field).replace("_", "-")) from None


def run(args: argparse.Namespace) -> int:
    from labjoint.batch.reprocess import SerialRunner, execute, plan_reprocess
    from labjoint.config import load_config
    from labjoint.storage.catalog import CATALOG_FILE, catalog_for
    from labjoint.storage.results import Results

    cfg = load_config(args.config)
    data = Path(args.data or cfg.rig.data_dir)
    if not cfg.rig.catalog_url and not (data / CATALOG_FILE).is_file():
        raise InputError("no run catalog here (run labjoint recover or import runs first)",
                         file=str(data))
    cat = catalog_for(cfg, data)
    records = cat.query(torque_nm=args.torque, vpp=args.vpp, frequency_hz=args.frequency,
                        status=args.status, plan=args.plan, limit=args.limit)
    opts = pipeline_options(args, data)
    results = Results(cat)
    distributed = args.scheduler != "none"
    plan = plan_reprocess(results, records, args.pipeline, opts, group_by=args.group_by,
                          force=args.recompute,
                          spread=distributed and args.pipeline in ("diagnose", "ladder"))
    show = not (args.json or args.quiet)
    bar = Progress(len(plan.tasks), f"reprocess {args.pipeline}", enabled=show)

    def progress(done: int, total: int, note: str) -> None:
        bar.advance(1, note=note)

    if not plan.tasks or not distributed:
        report = execute(plan, SerialRunner(), results, progress)
    else:
        from labjoint.batch.cluster import DaskRunner, dashboard_line, dask_client
        with dask_client(args.scheduler, args.workers) as client:
            if not args.quiet:
                sys.stderr.write(dashboard_line(client) + "\n")
            report = execute(plan, DaskRunner(client), results, progress)
    failed = [r for r in report["runs"] if r["status"] == "failed"]
    for r in failed:
        sys.stderr.write(terminal_safe(f"labjoint: error: run {r['run']}: {r['error']}") + "\n")
    if args.json:
        emit_json(report)
    else:
        print(table(["run", "status", "version"],
                    [[r["run"], r["status"], r["version"]] for r in report["runs"]]))
        print(f"\n{report['computed']} computed, {report['skipped']} skipped (current), "
              f"{report['not_applicable']} not applicable, {report['failed']} failed; "
              f"pipeline version {report['version']}")
    return 2 if failed else 0
