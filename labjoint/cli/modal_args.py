"""The modal kind's command-line options (fit, diagnose, ladder): the measured modes, the
joint between two points, the compared responses and the shaker between the voltage and
mode 1, or every mode with a two-point joint (:mod:`labjoint.structure.nlmode_shaker`)."""

from __future__ import annotations

import argparse
from typing import Any

from labjoint.errors import InputError

SHAKER_FLAGS = ("shaker", "drive_point", "modal_mass")


def add_modal_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--modal", default=None, metavar="MODES.json",
                   help="records of a structure nobody can describe: the measured modes (the "
                        "output of `labjoint modes RUN --json`); the model acts on mode 1's "
                        "coordinate, judged by simulation error of the measured responses")
    p.add_argument("--between", default=None, metavar="A,B",
                   help="with --modal: the joint acts on the relative displacement of these two "
                        "sensors of the modes (every mode carries it) instead of on mode 1")
    p.add_argument("--fit-joint-shape", action="store_true",
                   help="with --between: fit the joint's participation in modes 2..N (modal.joint<j>) "
                        "instead of taking it from the two sensors' shapes: a joint no sensor pair "
                        "sees as it moves (a lap that slips with the slope or curvature)")
    p.add_argument("--responses", default=None, metavar="A,B,...",
                   help="with --modal: the response channels compared (default every motion channel)")
    p.add_argument("--shaker-fit", default=None, metavar="A,B,...",
                   help="with --modal: shaker parameters (labjoint.models.shaker.Shaker fields) "
                        "to identify; each is refused by name with what the voltage-driven "
                        "records see of it instead")
    p.add_argument("--shaker", default=None, metavar="S.toml",
                   help="with --modal and a voltage drive: the electrodynamic shaker between the "
                        "voltage and mode 1, or every mode with --between (its [shaker] table; armature and two of Bl, R, "
                        "--modal-mass given, the third fitted); per-volt and per-newton predictions")
    p.add_argument("--drive-point", default=None, metavar="SENSOR",
                   help="with --shaker: the sensor of the modes at the shaker's attachment")
    p.add_argument("--modal-mass", type=float, default=None, metavar="KG",
                   help="with --shaker: mode 1's modal mass at the drive point, when known")


def modal_options(args: argparse.Namespace, start: dict[str, float],
                  bounds: dict[str, tuple[float, float]]) -> dict[str, Any]:
    """The modal options compare takes (``start``/``bounds`` from --start/--bound); the
    shaker flags without --modal, and shaker parameters the records cannot identify
    (--shaker-fit, :func:`labjoint.structure.nlmode.shaker_identifiable`), refused by name."""
    if args.shaker_fit:
        from labjoint.structure.nlmode import shaker_identifiable

        if not args.modal:
            raise InputError("--shaker-fit goes with --modal", field="shaker_fit")
        shaker_identifiable([n.strip() for n in args.shaker_fit.split(",") if n.strip()])
    if getattr(args, "fit_joint_shape", False) and not args.between:
        raise InputError("--fit-joint-shape goes with --modal and --between", field="fit_joint_shape")
    if not args.modal:
        given = [f for f in SHAKER_FLAGS if getattr(args, f, None) is not None]
        if given:
            raise InputError(f"--{given[0].replace('_', '-')} goes with --modal", field=given[0])
        return {}
    return {"start": start or None, "bounds": bounds or None, "shaker": args.shaker,
            "drive_point": args.drive_point, "modal_mass": args.modal_mass,
            "joint_shape": bool(getattr(args, "fit_joint_shape", False))}
