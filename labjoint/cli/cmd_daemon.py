"""`labjoint daemon`, `labjoint submit PLAN`, `labjoint torque JOB NM`."""

from __future__ import annotations

import argparse
import dataclasses

from labjoint.cli.output import emit_json


def add_daemon_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data", default=None, help="data directory (default: the config's data_dir)")


def add_submit_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("plan", help="plan file (TOML or JSON): plan = \"amplitude_sweep\" plus parameters")
    p.add_argument("--data", default=None, help="data directory (default: the config's data_dir)")


def add_torque_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("job", help="id of the job waiting for the torque change")
    p.add_argument("torque_nm", type=float, help="the torque now set on the bolt, Nm")
    p.add_argument("--data", default=None, help="data directory (default: the config's data_dir)")


def run(args: argparse.Namespace) -> int:
    from labjoint.cli.daemon_glue import run_daemon

    return run_daemon(args.config, args.data)


def _show(job: object, as_json: bool) -> None:
    d = dataclasses.asdict(job) if dataclasses.is_dataclass(job) else dict(job.__dict__)
    if as_json:
        emit_json(d)
    else:
        print(f"job {d.get('id')}: {d.get('status')} {d.get('message') or ''}".rstrip())


def submit(args: argparse.Namespace) -> int:
    from labjoint.cli.daemon_glue import submit_plan

    _show(submit_plan(args.plan, config_path=args.config, data_dir=args.data), args.json)
    return 0


def torque(args: argparse.Namespace) -> int:
    from labjoint.cli.daemon_glue import confirm_torque

    _show(confirm_torque(args.job, args.torque_nm, config_path=args.config, data_dir=args.data),
          args.json)
    return 0
