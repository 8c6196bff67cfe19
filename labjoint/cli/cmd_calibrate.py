"""`labjoint calibrate` and `labjoint friction`: identify the inputs later runs rely on.

- ``calibrate RUN...``: the nanocomposite shear-force sensor against the reference force
  sensor (seed 002 III.B, :func:`labjoint.identify.calibration.calibrate_runs`), one N/V
  point per run's frequency, kept in ``<data_dir>/calibrations.json``; the daemon and
  ``labjoint simulate`` apply the table to the channels of every later run.
- ``friction RUN``: mu from a macro-slip friction test (seed 002 Eq. 10,
  :func:`labjoint.identify.friction.identify_friction`), kept in
  ``<data_dir>/identified.json``, where ``labjoint analyze --method stickslip`` finds it.

Both refuse runs another plan recorded (``--any-plan`` to override); nothing is stored
unless every run given succeeds.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from labjoint.cli.output import emit_json, table
from labjoint.errors import InputError
from labjoint.storage.roles import channel_roles

CALIBRATION_PLAN = "sensor_calibration"
FRICTION_PLAN = "friction_test"


def in_file(exc: InputError, path: str | Path) -> InputError:
    """``exc`` naming ``path`` if it names no file yet."""
    return InputError(exc.message, file=exc.file or str(path), line=exc.line,
                      column=exc.column, field=exc.field)


def _data_dir(args: argparse.Namespace) -> Path:
    if args.data_dir:
        return Path(args.data_dir)
    from labjoint.config import load_config
    return Path(load_config(args.config).rig.data_dir)


def _number(text: str, allow_zero: bool) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(v) and (v >= 0 if allow_zero else v > 0)):
        raise argparse.ArgumentTypeError(
            f"must be a finite number {'>= 0' if allow_zero else '> 0'}, got {text!r}")
    return v


def _positive(text: str) -> float:
    return _number(text, allow_zero=False)


def _non_negative(text: str) -> float:
    return _number(text, allow_zero=True)


def _check_plan(md: dict[str, Any], want: str, path: str | Path, any_plan: bool) -> None:
    plan = md.get("plan")
    if plan is not None and plan != want and not any_plan:
        raise InputError(f"not a {want} run: it was recorded by plan {plan!r} "
                         f"(record one with plan = {want!r}, or pass --any-plan)",
                         file=str(path), field="plan")


# ---- calibrate ------------------------------------------------------------------------

def add_calibrate_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", nargs="+", metavar="RUN",
                   help="sensor-calibration run files (HDF5); a file that cannot be used is "
                        "reported by name and the others are used (exit status 1; 2 if none "
                        "could be used, and then nothing is stored)")
    p.add_argument("--channel", default=None,
                   help="sensor channel to calibrate (default: the run's joint_force_channel)")
    p.add_argument("--data-dir", default=None,
                   help="where calibrations.json lives (default: the config's data_dir)")
    p.add_argument("--beam-mass", type=_positive, default=None, metavar="KG",
                   help="beam-1 mass (default: the run's beam_mass_kg)")
    p.add_argument("--support-stiffness", type=_non_negative, default=None, metavar="N_PER_M",
                   help="beam-1 support stiffness (default: the run's metadata, else 0)")
    p.add_argument("--support-damping", type=_non_negative, default=None, metavar="NS_PER_M",
                   help="beam-1 support damping (default: the run's metadata, else 0)")
    p.add_argument("--any-plan", action="store_true",
                   help="accept runs recorded by plans other than sensor_calibration")


def check_calibration_run(path: str | Path, channel: str | None, any_plan: bool) -> str:
    """Refuse what cannot be a calibration record (InputError naming file and field);
    returns the sensor channel's name."""
    from labjoint.storage import is_csv, open_run

    p = Path(path)
    if is_csv(p):
        raise InputError("calibration needs an acquired HDF5 run (raw sensor volts), "
                         "not an imported CSV file", file=str(p))
    with open_run(p) as rf:
        md = rf.metadata
        _check_plan(md, CALIBRATION_PLAN, p, any_plan)
        roles = channel_roles(md, rf.channel_names)
        sensor = channel or roles.joint_force
        ref, disp1 = roles.reference_force, roles.displacement[0]
        names = rf.channel_names
        for role, name in (("sensor channel", sensor), ("reference force channel", ref),
                           ("beam-1 displacement channel", disp1)):
            if name not in names:
                raise InputError(f"run has no {role} {name!r} to calibrate with; channels: "
                                 f"{names}", file=str(p),
                                 field="--channel" if role == "sensor channel" and channel
                                 else name)
        if sensor == ref:
            raise InputError(f"the sensor channel {sensor!r} is the reference itself",
                             file=str(p), field="--channel")
        if rf.channel(sensor).sensor == "imported":
            raise InputError("imported runs hold no raw sensor volts", file=str(p), field=sensor)
    return sensor


def calibrate_files(paths: list[str], data_dir: Path, *, channel: str | None = None,
                    any_plan: bool = False, **dynamics: Any
                    ) -> tuple[list[dict[str, Any]], Any, list[dict[str, str]]]:
    """Calibrate every usable run and add the points to ``<data_dir>/calibrations.json``
    (written once, atomically); returns (point rows, the store, the refused files).

    Every run is checked and computed before anything is written. A run that cannot be
    used (not a calibration record, clipped, damaged, ...) is reported with its file
    name and the reason, and the others are used; if none can be used, InputError
    names them all and nothing is stored.
    """
    from labjoint.identify.calibration import CalibrationStore, calibrate_run, calibrate_runs

    kw = {k: v for k, v in dynamics.items() if v is not None}
    good, sensors, failed = [], [], []
    for p in paths:
        try:
            sensor = check_calibration_run(p, channel, any_plan)
            calibrate_run(p, channel=channel, **kw)          # dry run: fail before writing
        except InputError as exc:
            err = in_file(exc, p)
            failed.append({"file": str(p), "error": str(err)})
            continue
        good.append(p)
        sensors.append(sensor)
    if not good:
        if len(failed) == 1:
            raise InputError(failed[0]["error"])
        raise InputError(f"no usable calibration run among {len(paths)}: "
                         + "; ".join(f["error"] for f in failed))
    store = CalibrationStore.open(data_dir)
    points = calibrate_runs(good, store, channel=channel, **kw)
    rows = [{"file": str(p), "run": q.runs[0] if q.runs else Path(p).stem, "channel": s,
             "frequency_hz": q.frequency_hz, "n_per_v": q.n_per_v, "uncertainty": q.uncertainty,
             "phase_deg": q.phase_deg, "phase_uncertainty_deg": q.phase_uncertainty_deg,
             "n_blocks": q.n_blocks, "beam_mass_kg": q.beam_mass_kg}
            for p, s, q in zip(good, sensors, points)]
    return rows, store, failed


def calibrate(args: argparse.Namespace) -> int:
    data_dir = _data_dir(args)
    rows, store, failed = calibrate_files(args.runs, data_dir, channel=args.channel,
                                  any_plan=args.any_plan, beam_mass_kg=args.beam_mass,
                                  support_stiffness_n_per_m=args.support_stiffness,
                                  support_damping_ns_per_m=args.support_damping)
    channels = sorted({r["channel"] for r in rows})
    tables = {c: [{"frequency_hz": q.frequency_hz, "n_per_v": q.n_per_v,
                   "uncertainty": q.uncertainty, "runs": list(q.runs)}
                  for q in store.channels.get(c, [])] for c in channels}
    for f in failed:
        print(f"not used: {f['error']}", file=sys.stderr)
    status = 1 if failed else 0
    if args.json:
        emit_json({"store": str(store.path), "points": rows, "tables": tables, "failed": failed})
        return status
    for c in channels:
        print(f"{c}: calibration table in {store.path}")
        print(table(["f Hz", "N/V", "+- N/V", "runs"],
                    [[t["frequency_hz"], t["n_per_v"], t["uncertainty"], ", ".join(t["runs"])]
                     for t in tables[c]]))
    print(f"\n{len(rows)} point(s) added; later runs in {data_dir} use them "
          "(interpolated at each run's frequency)")
    if failed:
        print(f"{len(failed)} file(s) not used (see above)")
    return status


# ---- friction -------------------------------------------------------------------------

def add_friction_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run", metavar="RUN", help="friction-test run (HDF5, or CSV import format)")
    p.add_argument("--torque-to-normal", type=_positive, default=None, metavar="N_PER_NM",
                   help="bolt normal force per N*m of torque (default: the run's normal_force_n, "
                        "else its torque x its ratio, seed 002: 478)")
    p.add_argument("--data-dir", default=None,
                   help="where identified.json lives (default: the config's data_dir)")
    p.add_argument("--any-plan", action="store_true",
                   help="accept runs recorded by plans other than friction_test")


def friction_from_file(path: str | Path, torque_to_normal: float | None = None,
                       any_plan: bool = False) -> Any:
    """mu (an :class:`~labjoint.identify.friction.Identified`) from a friction-test file."""
    from labjoint.cli.inputs import load_runs
    from labjoint.identify.friction import identify_friction
    from labjoint.storage import read_run

    try:
        (item,) = load_runs([str(path)])
        run = read_run(item) if isinstance(item, Path) else item
        _check_plan(run.metadata, FRICTION_PLAN, path, any_plan)
        return identify_friction(run, torque_to_normal_n_per_nm=torque_to_normal)
    except InputError as exc:
        raise in_file(exc, path) from None


def friction(args: argparse.Namespace) -> int:
    from labjoint.identify.identified import save_identified

    mu = friction_from_file(args.run, args.torque_to_normal, args.any_plan)
    stored = save_identified(_data_dir(args), mu)
    d = mu.details
    row = {"run": mu.source, "file": str(args.run), "friction_coefficient": mu.value,
           "uncertainty": mu.uncertainty, "sliding_force_n": d.get("sliding_force_n"),
           "normal_force_n": d.get("normal_force_n"), "slip_fraction": d.get("slip_fraction"),
           "cycles": mu.n_cycles, "method": mu.method, "store": str(stored)}
    if args.json:
        emit_json(row)
    else:
        print(f"mu = {mu.value:.4g} +- {mu.uncertainty:.2g} from {mu.source} "
              f"(f_sld = {row['sliding_force_n']:.4g} N, f_n = {row['normal_force_n']:.4g} N, "
              f"seed 002 Eq. 10); stored in {stored}")
    return 0
