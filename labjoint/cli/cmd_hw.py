"""`labjoint hw check`: list instruments and DAQ devices; exit code 3 when a configured
instrument does not answer (0 when the rig is ready)."""

from __future__ import annotations

import argparse

from labjoint.cli.output import emit_json


def add_hw_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("action", choices=["check"], help="check: list instruments and DAQ devices")


def run(args: argparse.Namespace) -> int:
    from labjoint.config import load_config
    from labjoint.hardware.check import format_check, hardware_check

    result = hardware_check(load_config(args.config))
    if args.json:
        emit_json(result)
    else:
        print(format_check(result))
    return 0 if result["ok"] else 3     # an unreachable configured instrument (as HardwareError)
