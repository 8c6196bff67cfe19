"""`labjoint` command line: one subcommand per job; `--json` prints one JSON object.

Errors go to stderr as one line with a non-zero exit code (2: bad input, 3: hardware,
4: safety limit, 1: anything else).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from typing import Sequence

from labjoint import __version__
from labjoint.errors import HardwareError, InputError, LabjointError, LimitExceeded

# subcommand -> (module in labjoint.cli, function, help)
COMMANDS = {
    "simulate": ("cmd_simulate", "run", "run a plan on the simulated rig and analyse it"),
    "import": ("cmd_import", "run", "import CSV, MAT, UFF, TDMS or HDF5 files into run files"),
    "export": ("cmd_export", "run", "write runs as universal files (UFF 58) for modal tools"),
    "analyze": ("cmd_analyze", "run", "identify energy loss, damping and stiffness of runs"),
    "calibrate": ("cmd_calibrate", "calibrate", "calibrate the joint-force sensor (N/V per frequency)"),
    "friction": ("cmd_calibrate", "friction", "identify mu from a friction-test run and store it"),
    "runs": ("cmd_runs", "run", "query the run catalog"),
    "reprocess": ("cmd_reprocess", "run", "rerun a pipeline over catalogued runs (Dask); "
                  "current results are skipped"),
    "recover": ("cmd_recover", "run", "close run files whose writer died; fix the catalog"),
    "fit": ("cmd_models", "fit", "fit a joint model to runs"),
    "diagnose": ("cmd_models", "diagnose", "where a model fails and which effect is missing"),
    "ladder": ("cmd_models", "ladder", "add effects until the model is adequate"),
    "frf": ("cmd_frf", "run_frf", "FRFs (H1, H2, Hv, coherence, std) of broadband records, one level per record"),
    "modes": ("cmd_frf", "run_modes", "natural frequency, damping and mode shape per level (LSCF/LSFD, half-power)"),
    "distortion": ("cmd_distortion", "run", "harmonics of steady sines; odd/even distortion of multisines"),
    "predict": ("cmd_predict", "run", "simulate a saved model on a record's force"),
    "shaker": ("cmd_shaker", "run", "identify the shaker with the structure's modes from a low-level FRF set"),
    "structure": ("cmd_structure", "run", "assembled-structure model: modes, stage-1 update, nonlinear FRF"),
    "backbone": ("cmd_backbone", "run", "frequency and damping against amplitude: measured and modelled"),
    "hw": ("cmd_hw", "run", "hardware: `labjoint hw check` lists instruments and DAQ devices"),
    "daemon": ("cmd_daemon", "run", "run the headless acquisition daemon"),
    "submit": ("cmd_daemon", "submit", "queue a plan (TOML/JSON) for the daemon"),
    "status": ("cmd_status", "status", "is the daemon alive, what is it doing, how many jobs"),
    "jobs": ("cmd_status", "jobs", "the daemon's plan jobs (newest first)"),
    "resume": ("cmd_status", "resume", "resume a plan held by an emergency stop"),
    "torque": ("cmd_daemon", "torque", "confirm the new bolt torque so a paused plan continues"),
    "serve": ("cmd_serve", "run", "run the REST service (and, by default, the daemon on the simulated rig)"),
}


def _add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--config", default=None, help="rig config TOML (default: the simulated rig)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="labjoint", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"labjoint {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, (mod, _fn, help_) in COMMANDS.items():
        p = sub.add_parser(name, help=help_, description=help_)
        _add_common(p)
        try:
            module = importlib.import_module(f"labjoint.cli.{mod}")
        except ModuleNotFoundError as exc:  # a command whose layer is not installed
            if exc.name != f"labjoint.cli.{mod}":
                raise
            sub._name_parser_map.pop(name, None)
            sub._choices_actions[:] = [a for a in sub._choices_actions if a.dest != name]
            continue
        getattr(module, f"add_{name}_arguments")(p)
        p.set_defaults(_handler=(mod, _fn, name))
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    mod, fn, _name = args._handler
    handler = getattr(importlib.import_module(f"labjoint.cli.{mod}"), fn)
    from labjoint.cli.output import install_terminal_log

    install_terminal_log()           # warnings as escaped lines (never raw bytes)
    try:
        return int(handler(args) or 0)
    except InputError as exc:
        return _fail(exc, 2)
    except LimitExceeded as exc:
        return _fail(exc, 4)
    except HardwareError as exc:
        return _fail(exc, 3)
    except LabjointError as exc:
        return _fail(exc, 1)
    except KeyboardInterrupt:
        return _fail("interrupted", 130)


def _fail(exc: object, code: int) -> int:
    from labjoint.cli.output import terminal_safe

    sys.stderr.write(f"labjoint: error: {terminal_safe(exc)}\n")   # never raw bytes
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
