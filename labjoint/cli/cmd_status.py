"""`labjoint status` and `labjoint jobs`: the daemon's liveness and state, and the plan
jobs of its queue (the config's ``<data_dir>/queue.sqlite`` unless ``--data``)."""

from __future__ import annotations

import argparse
from typing import Any

from labjoint.cli.output import emit_json, table


def add_status_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data", default=None, help="data directory (default: the config's data_dir)")


def add_jobs_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data", default=None, help="data directory (default: the config's data_dir)")
    p.add_argument("--status", default=None,
                   help="only jobs in this state (queued, running, waiting_torque, complete, "
                        "failed, cancelled, aborted)")
    p.add_argument("--limit", type=int, default=50, help="at most this many, newest first")


def _queue(args: argparse.Namespace) -> Any:
    from labjoint.cli.daemon_glue import open_queue

    return open_queue(config_path=args.config, data_dir=args.data)


def status(args: argparse.Namespace) -> int:
    from labjoint.daemon.liveness import liveness

    q = _queue(args)
    d = liveness(q)
    res = {"daemon": d, "jobs": q.counts(), "estop": q.estop_requested(),
           "queue_db": str(q.db_path)}
    if args.json:
        emit_json(res)
        return 0
    age = d.get("heartbeat_age_s")
    beat = "never" if age is None else f"{age:.0f} s ago"
    print(f"daemon: {d['state']} (last heartbeat {beat}"
          + (f", pid {d['pid']}" if d.get("running") and d.get("pid") else "") + ")")
    if d.get("job"):
        print(f"job {d['job']} ({d.get('plan')}): run {d.get('run')}, {d.get('samples', 0)} samples")
    if d.get("last_error"):
        print(f"last error: {d['last_error']}")
    if res["estop"]:
        print(f"EMERGENCY STOP pending: {res['estop']}")
    print("jobs: " + (", ".join(f"{k} {v}" for k, v in res["jobs"].items()) or "none"))
    return 0


def jobs(args: argparse.Namespace) -> int:
    from labjoint.errors import InputError

    if args.limit < 1:
        raise InputError(f"must be >= 1, got {args.limit}", field="--limit")
    rows = [j.to_dict() for j in _queue(args).list(status=args.status, limit=args.limit)]
    if args.json:
        emit_json({"jobs": rows})
        return 0
    print(table(["id", "plan", "status", "submitted", "message"],
                [[j["id"][:8], j["plan"].get("plan"), j["status"], j.get("submitted_at", ""),
                  (j.get("message") or "")[:50]] for j in rows]))
    return 0


def add_resume_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("job", help="id of a plan job held by an emergency stop")
    p.add_argument("--data", default=None, help="data directory (default: the config's data_dir)")


def resume(args: argparse.Namespace) -> int:
    """A plan held by an emergency stop back to the queue (the stop must be cleared)."""
    job = _queue(args).resume(args.job)
    if args.json:
        emit_json(job.to_dict())
    else:
        print(f"job {job.id}: {job.status}")
    return 0
