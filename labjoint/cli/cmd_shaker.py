"""`labjoint shaker FRF.json --drive SENSOR [--given S.toml]`: the shaker identified with the
structure's modes from a low-level test's FRF set (:mod:`labjoint.models.shaker_fit`)."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from labjoint.cli.output import emit_json, table
from labjoint.errors import InputError


def add_shaker_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("frf", metavar="FRF.json", help="an FRF set (`labjoint frf` or `structure measured`) "
                                                   "whose drive is a voltage, or a force with the voltage beside")
    p.add_argument("--drive", required=True, metavar="SENSOR",
                   help="the response sensor at the shaker's attachment (the drive point)")
    p.add_argument("--given", default=None, metavar="S.toml",
                   help="a structure or model file whose [shaker] table gives what is known (SI)")
    p.add_argument("--modal-mass", type=float, default=None, metavar="KG",
                   help="mode 1's modal mass at the drive point, when known (a scale of the structure)")
    p.add_argument("--modes", type=int, default=1, metavar="N", help="structural modes in the band (default 1)")
    p.add_argument("--band", default=None, metavar="LO:HI", help="frequency band in Hz (default: all lines)")
    p.add_argument("--full", action="store_true",
                   help="with --json: the model's FRFs per volt (and the force per volt) and per newton, "
                        "each sensor in the set's quantity, at the set's frequencies ({re, im})")


def per_volt(fs: Any, band: tuple[float, float] | None) -> tuple[np.ndarray, dict[str, np.ndarray], Any]:
    """(frequencies, per-volt responses by sensor, force per volt or None) of the set's
    lowest level (the linear test)."""
    lv = float(np.min(fs.level_n))
    keep = fs.level_n == lv
    if band is not None:
        keep &= (fs.frequencies_hz >= band[0]) & (fs.frequencies_hz <= band[1])
    idx = np.flatnonzero(keep)
    idx = idx[np.argsort(fs.frequencies_hz[idx], kind="stable")]
    f = fs.frequencies_hz[idx]
    if fs.drive_quantity == "voltage":
        volts, force = fs.force[idx], None
    elif fs.drive_v is not None:
        volts, force = fs.drive_v[idx], fs.force[idx] / fs.drive_v[idx]
    else:
        raise InputError("the FRF set's drive is a force and holds no voltage: the shaker is not in it "
                         "(drive_v)", field="frf")
    if np.any(volts == 0):
        raise InputError("a step's voltage phasor is zero", field="frf")
    resp = {s: fs.response[idx, i, 0] / volts for i, s in enumerate(fs.sensors)}
    return f, resp, force


def _band(text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        raise InputError(f"must be LO:HI in Hz, got {text!r}", field="band") from None
    if not 0 <= lo < hi:
        raise InputError(f"must be 0 <= LO < HI, got {text!r}", field="band")
    return lo, hi


def run(args: argparse.Namespace) -> int:
    from labjoint.models.shaker import shaker_table
    from labjoint.models.shaker_fit import identify
    from labjoint.signal.frfset import RESPONSE_UNITS, FrfSet

    fs = FrfSet.load(args.frf)
    f, resp, force = per_volt(fs, _band(args.band))
    if args.drive not in resp:
        raise InputError(f"no sensor {args.drive!r}; sensors: {list(resp)}", file=args.frf, field="drive")
    given: dict[str, float] = dict(shaker_table(args.given)) if args.given else {}
    if args.modal_mass is not None:
        if not args.modal_mass > 0:
            raise InputError(f"must be a positive mass in kg, got {args.modal_mass}", field="modal_mass")
        given["mode1.mass_kg"] = float(args.modal_mass)
    fit = identify(f, resp, args.drive, quantities={s: fs.quantity for s in resp},
                   force_per_volt_measured=force, given=given, n_modes=args.modes)
    res = {"frf": str(args.frf), "drive": args.drive, "force_measured": fit.force_measured,
           "shaker": fit.shaker.to_dict(), "parameters": fit.parameters(),
           "identified": list(fit.identified), "given": list(fit.given), "misfit": fit.misfit,
           "modes": [{"frequency_hz": a, "damping_ratio": b, "mass_kg": c} for a, b, c in
                     zip(fit.structure.frequencies_hz, fit.structure.damping_ratios, fit.structure.masses_kg)]}
    if args.json:
        if args.full:
            pack = lambda d: {k: {"re": v.real.tolist(), "im": v.imag.tolist()} for k, v in d.items()}  # noqa: E731
            unit = RESPONSE_UNITS[fs.quantity]
            res.update(frequencies_hz=f.tolist(), units={"per_volt": f"{unit}/V", "per_newton": f"{unit}/N"},
                       per_volt=pack(fit.per_volt(f)), per_newton=pack(fit.per_newton(f)))
        emit_json(res)
        return 0
    print(table(["parameter", "value", "stderr", "given"],
                [[k, v["value"], v["stderr"], "yes" if v["given"] else ""] for k, v in res["parameters"].items()]))
    for k, v in res["parameters"].items():
        if v.get("flag"):
            print(f"warning: {k}: {v['flag']}")
    print(f"\nrms relative misfit of the FRFs per volt: {100 * fit.misfit:.3g} %")
    return 0
