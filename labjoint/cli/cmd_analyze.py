"""`labjoint analyze RUN... [--method loop|stickslip|both] [--friction MU | --friction-run RUN]
[--cutoff HZ|none] [--data-dir DIR] [--table] [--json]`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from labjoint.cli.limits import plausibility
from labjoint.cli.inputs import load_runs
from labjoint.cli.output import Progress, emit_json, table
from labjoint.errors import InputError, LabjointError

#: design.md's analyze fields, in order.
FIELDS = ("run", "frequency_hz", "displacement_amplitude_m", "force_amplitude_n",
          "energy_loss_j", "damping_ns_per_m", "stiffness_n_per_m", "cycles")


def add_analyze_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", nargs="+", metavar="RUN", help="HDF5 run file or CSV file (import format)")
    p.add_argument("--method", choices=["loop", "stickslip", "both"], default=None,
                   help="hysteresis loop (seed 002 Eq. 1), stick-slip boundary (Eqs. 2-9) or "
                        "both (default: loop; with --table both when mu is known)")
    p.add_argument("--force", choices=["joint", "reference"], default="joint",
                   help="force sensor: the nanocomposite joint sensor (default) or the reference")
    mu = p.add_mutually_exclusive_group()
    mu.add_argument("--friction", type=float, default=None,
                    help="friction coefficient for --method stickslip (default: the identified one)")
    mu.add_argument("--friction-run", default=None, metavar="RUN",
                    help="identify the friction coefficient from this friction-test run "
                         "(seed 002 Eq. 10) for this analysis")
    p.add_argument("--data-dir", default=None,
                   help="where the identified friction coefficient is kept "
                        "(default: the config's data_dir)")
    p.add_argument("--save", action="store_true",
                   help="store results in each run file: processed/loop (methods loop, both) "
                        "and processed/stickslip (stickslip, both)")
    p.add_argument("--cutoff", type=_cutoff, default=None, metavar="HZ|none",
                   help="low-pass cutoff of the loop method (default: seed 002's 3 kHz, "
                        "capped at 0.45 fs); 'none': no filter. For fundamentals the 3 kHz "
                        "filter would attenuate (it refuses them, naming the cutoff needed)")
    p.add_argument("--max-displacement", type=float, default=None, metavar="M",
                   help="largest plausible displacement amplitude (m) of the loop method (default "
                        "the rig config's [plausibility] max_displacement_amplitude_m, else 0.01 m)")
    p.add_argument("--table", action="store_true",
                   help="the trends of the runs: seed 002 Tables 2-4 (both methods, with "
                        "uncertainties) and the dissipation exponent W ~ F^n with its 95 %% "
                        "interval (seed 001); with --json the rows gain the uncertainties "
                        "and a 'trend' object holds the fits and the table")


def _cutoff(text: str) -> float | str:
    """``--cutoff``: a frequency in Hz, or 'none' (no low-pass)."""
    if text.strip().lower() == "none":
        return "none"
    try:
        hz = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a frequency in Hz or 'none': {text!r}") from None
    if not hz > 0 or hz == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive frequency in Hz, got {text!r}")
    return hz


def _cutoff_hz(cutoff: float | str | None) -> float | None:
    """The analysis's ``cutoff_hz`` for a ``--cutoff`` value (None: the default)."""
    from labjoint.signal.filter import PAPER_CUTOFF_HZ
    return PAPER_CUTOFF_HZ if cutoff is None else None if cutoff == "none" else float(cutoff)


def loop_row(item: Any, force: str, save: bool, cutoff: float | str | None = None,
             plausibility: Any = None) -> dict[str, Any]:
    from labjoint.identify.analyze import analyze_file, analyze_run

    if isinstance(item, Path):
        res = analyze_file(item, force=force, cutoff_hz=_cutoff_hz(cutoff), plausibility=plausibility)
        name = res.metadata.get("run", item.stem)
        extra = {k: res.metadata.get(k) for k in ("excitation_vpp", "torque_nm")}
        if save:
            from labjoint.identify.methods import loop_processed
            from labjoint.storage import write_processed
            write_processed(item, "loop", *loop_processed(res))
    else:
        if force != "joint":
            raise InputError("an imported CSV record has one force column; --force reference "
                             "applies to run files only", file=str(item.path or item.name),
                             field="--force")
        res = analyze_run(item, cutoff_hz=_cutoff_hz(cutoff), plausibility=plausibility)
        name = item.name
        extra = {k: item.metadata.get(k) for k in ("excitation_vpp", "torque_nm")}
    row = {"run": name}
    row.update({k: res.summary.get(k) for k in FIELDS if k != "run"})
    row.update({k: v for k, v in res.summary.items() if k not in row})
    row.update(extra)
    from labjoint.compare.flags import energy_flag

    flag = energy_flag(str(name), float(row.get("energy_loss_j") or float("nan")),
                       float(row.get("energy_loss_j_uncertainty") or 0.0))
    if flag:
        row["flags"] = [flag]
    return row


def analyze_paths(paths: list[str], method: str = "loop", force: str = "joint",
                  friction: Any = None, save: bool = False, data_dir: str | None = None,
                  progress: bool = False, friction_run: str | None = None,
                  errors: list[dict[str, str]] | None = None,
                  cutoff: float | str | None = None, plausibility: Any = None) -> list[dict[str, Any]]:
    """Rows of ``labjoint analyze``; ``friction`` a number or Identified, or ``friction_run``
    a friction-test file mu is identified from (else the one stored in ``data_dir``);
    ``cutoff`` the loop method's low-pass (Hz, "none", or None for the default).

    With ``errors`` a list, a file that cannot be analysed (missing, unreadable, a missing
    channel, not a sine ...) is noted there as {"file", "error"} and the others go on;
    without it the first such error is raised."""
    if cutoff is not None and method != "loop":
        raise InputError("applies to --method loop (the stick-slip method keeps its own "
                         "filtering)", field="--cutoff")
    if friction_run is not None:
        if method == "loop":
            raise InputError("applies to --method stickslip or both", field="--friction-run")
        if friction is not None:
            raise InputError("give --friction or --friction-run, not both", field="--friction-run")
        from labjoint.cli.cmd_calibrate import friction_from_file
        friction = friction_from_file(friction_run)
    if isinstance(friction, (int, float)) and method != "loop":   # once, before any file
        from labjoint.identify.stickslip import check_friction
        check_friction(friction, field="--friction")
    bar = Progress(len(paths), "analyze", enabled=progress)
    rows: list[dict[str, Any]] = []
    for p in paths:
        try:
            (item,) = load_runs([p])
            if method == "loop":
                rows.append(loop_row(item, force, save, cutoff, plausibility))
            else:
                from labjoint.identify.methods import analyze_runs
                rows += analyze_runs([item], method, friction=friction, data_dir=data_dir,
                                     store=save, force=force)
        except LabjointError as exc:
            if errors is None:
                raise
            msg = str(exc)
            errors.append({"file": str(p), "error": msg[len(f"{p}: "):]
                           if msg.startswith(f"{p}: ") else msg})
        bar.advance(note=Path(p).name)
    return rows


def print_loop_table(rows: list[dict[str, Any]]) -> None:
    """The loop table; W and C below their resolution are printed as such, not as numbers."""
    out = table(["run", "f Hz", "Vpp", "U um", "F N", "W mJ", "+- mJ", "C Ns/m", "K MN/m",
                 "cycles"],
                [[r["run"], r.get("frequency_hz"), r.get("excitation_vpp"),
                  _scale(r.get("displacement_amplitude_m"), 1e6), r.get("force_amplitude_n"),
                  *_w_c(r), _scale(r.get("stiffness_n_per_m"), 1e-6), r.get("cycles")]
                 for r in rows])
    print(out)
    for r in rows:
        for f in r.get("flags") or []:
            print(f"warning: run {r['run']}: {f['message']}")
    if any(r.get("below_resolution") for r in rows):
        print(f"\n{BELOW}: W is under twice its uncertainty (sensor phase and cycle-to-cycle "
              "scatter, at least 2 pi K U^2 u_phase): not a measurement of W or C; the JSON "
              "output keeps the numbers with below_resolution = true")


BELOW = "below resolution"


def _w_c(r: dict[str, Any]) -> list[Any]:
    """W (mJ), its uncertainty, and C, or the 'below resolution' flag in their place."""
    u = _scale(r.get("energy_loss_j_uncertainty"), 1e3)
    if r.get("below_resolution"):
        return [BELOW, u, BELOW]
    return [_scale(r.get("energy_loss_j"), 1e3), u, r.get("damping_ns_per_m")]


def _scale(v: Any, k: float) -> Any:
    return None if v is None else float(v) * k


def trends_table(args: argparse.Namespace, data_dir: str | None,
                 errors: list[dict[str, str]]) -> dict[str, Any]:
    """:func:`labjoint.identify.trends.build_trends` of the runs: both methods when the
    friction coefficient is given, identified from --friction-run or stored (else the
    loop alone, said in the notes), the loop alone with --method loop."""
    from labjoint.identify.identified import load_identified
    from labjoint.identify.trends import build_trends, trend_rows

    friction: Any = args.friction
    if args.friction_run is not None:
        if args.method == "loop":
            raise InputError("applies to --method stickslip or both", field="--friction-run")
        from labjoint.cli.cmd_calibrate import friction_from_file
        friction = friction_from_file(args.friction_run)
    if friction is None and args.method != "loop" and data_dir is not None:
        friction = load_identified(data_dir, "friction_coefficient")
    if args.method == "loop":
        friction = None
    elif friction is None and args.method is not None:
        raise InputError("the stick-slip method needs the friction coefficient: give "
                         "--friction MU or --friction-run RUN, or identify it first "
                         "(labjoint friction RUN)", field="--friction")
    bar = Progress(len(args.runs), "analyze", enabled=not (args.json or args.quiet))
    rows: list[dict[str, Any]] = []
    for p in args.runs:
        try:
            (item,) = load_runs([p])
            rows += trend_rows([item], friction, force=args.force)
        except LabjointError as exc:
            msg = str(exc)
            errors.append({"file": str(p), "error": msg[len(f"{p}: "):]
                           if msg.startswith(f"{p}: ") else msg})
        bar.advance(note=Path(p).name)
    for r in rows:
        r["force_sensor"] = args.force
    return build_trends(rows)


def run(args: argparse.Namespace) -> int:
    if args.table:
        return _run_table(args)
    args.method = args.method or "loop"
    data_dir = args.data_dir
    if args.method != "loop" and data_dir is None:
        from labjoint.config import load_config
        data_dir = load_config(args.config).rig.data_dir
    errors: list[dict[str, str]] = []
    rows = analyze_paths(args.runs, args.method, args.force, args.friction, args.save, data_dir,
                         progress=not (args.json or args.quiet), friction_run=args.friction_run,
                         errors=errors, cutoff=args.cutoff, plausibility=plausibility(args))
    for e in errors:
        sys.stderr.write(f"labjoint: error: {e['file']}: {e['error']}\n")
    code = 2 if errors else 0
    if errors and not rows:
        return code                       # nothing but errors: stderr only
    if args.json:
        emit_json({"runs": rows, "errors": errors})
        return code
    elif args.method == "loop":
        print_loop_table(rows)
    else:
        from labjoint.identify.methods import MODEL_NOTE, format_table
        print(format_table(rows))
        print("\n" + MODEL_NOTE)
    return code


def _run_table(args: argparse.Namespace) -> int:
    """``labjoint analyze --table``: the trends table on stdout (or JSON: the design.md
    ``runs`` rows and a ``trend`` object), errors per file on stderr."""
    from labjoint.identify.trends import format_trends

    if args.save:
        raise InputError("stores nothing with --table: run without --table to save",
                         field="--save")
    data_dir = args.data_dir
    if data_dir is None and args.method != "loop":
        from labjoint.config import load_config
        data_dir = load_config(args.config).rig.data_dir
    errors: list[dict[str, str]] = []
    if args.cutoff is not None:
        raise InputError("applies to the loop table (labjoint analyze without --table)",
                         field="--cutoff")
    body = trends_table(args, data_dir, errors)
    for e in errors:
        sys.stderr.write(f"labjoint: error: {e['file']}: {e['error']}\n")
    code = 2 if errors else 0
    if errors and not body["runs"]:
        return code
    if args.json:
        trend = {k: v for k, v in body.items() if k not in ("runs", "errors")}
        emit_json({"runs": body["runs"], "errors": errors, "trend": trend})
    else:
        print(format_trends(body))
    return code
