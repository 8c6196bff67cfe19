"""`labjoint simulate`: run a plan on the simulated rig, write run files, print results.

The default is seed 002's amplitude sweep (Table 3) at 400 Hz and 5 Nm. Sensor
calibrations stored in the output directory (``labjoint calibrate``) are applied to the
channels first; each run's metadata records the factor it is read with.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path
from typing import Any

from labjoint.cli.output import Progress, emit_json, terminal_safe
from labjoint.errors import InputError


def _floats(text: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None


def _effect(text: str) -> dict[str, Any]:
    """``name:k=v,k=v`` -> {"name": name, k: v}."""
    name, _, rest = text.partition(":")
    eff: dict[str, Any] = {"name": name.strip()}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, val = item.partition("=")
        if not eq:
            raise argparse.ArgumentTypeError(f"effect parameter {item!r} must be key=value")
        try:
            eff[key.strip()] = float(val)
        except ValueError:
            raise argparse.ArgumentTypeError(f"effect parameter {key!r} needs a number, got {val!r}") from None
    return eff


def add_simulate_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--sweep", type=_floats, default=[1.0, 4.0, 8.0, 12.0, 16.0, 20.0],
                   help="excitation levels in Vpp, comma-separated (default: seed 002 Table 3)")
    p.add_argument("--plan", default=None, help="a plan file (TOML/JSON) instead of --sweep")
    p.add_argument("--frequency", type=float, default=400.0, help="excitation frequency, Hz")
    p.add_argument("--torque", type=float, default=5.0, help="bolt torque, Nm")
    p.add_argument("--cycles", type=int, default=100, help="steady cycles recorded per run")
    p.add_argument("--sample-rate", type=float, default=None, help="DAQ sample rate, S/s")
    p.add_argument("--seed", type=int, default=None, help="simulator random seed")
    p.add_argument("--effect", type=_effect, action="append", default=[],
                   help="inject an effect into the simulated joint: NAME:k=v,... (repeatable)")
    p.add_argument("--out", default=None, help="data directory (default: the config's data_dir)")


def run(args: argparse.Namespace) -> int:
    from labjoint.acquisition.admission import check_plan
    from labjoint.acquisition.plans import load_plan, read_plan_file
    from labjoint.acquisition.rig import open_rig
    from labjoint.acquisition.stop_signals import stop_on_signals
    from labjoint.cli.cmd_analyze import analyze_paths, print_loop_table
    from labjoint.cli.signals import terminate_as_interrupt
    from labjoint.config import load_config
    from labjoint.daemon.setup import calibrated_config
    from labjoint.storage.catalog import catalog_for
    from labjoint.storage.writer import RunWriter

    overrides: dict[str, Any] = {"rig": {"backend": "sim"}}
    sim: dict[str, Any] = {}
    if args.seed is not None:
        sim["seed"] = args.seed
    if args.effect:
        sim["effects"] = args.effect
    if sim:
        overrides["sim"] = sim
    if args.sample_rate is not None:
        overrides["daq"] = {"sample_rate_hz": args.sample_rate}
    cfg = load_config(args.config, overrides)
    if args.cycles < 1:
        raise InputError("must be at least 1", field="--cycles")
    spec = (read_plan_file(Path(args.plan)) if args.plan else
            {"plan": "amplitude_sweep", "amplitudes_vpp": args.sweep,
             "frequency_hz": args.frequency, "torque_nm": args.torque, "n_cycles": args.cycles})
    try:                           # the admission check submit and REST apply
        check_plan(spec, cfg)
    except InputError as exc:
        raise InputError(exc.message, file=args.plan or exc.file, field=exc.field) from None
    plan = load_plan(spec)
    out = Path(args.out or cfg.rig.data_dir)
    out.mkdir(parents=True, exist_ok=True)
    cfg, sources = calibrated_config(cfg, out)
    n_runs = len(args.sweep) if not args.plan else 1
    bar = Progress(n_runs, "simulate", enabled=not (args.json or args.quiet))
    writer = RunWriter(out, catalog=catalog_for(cfg, out))

    unconverged: list[str] = []        # step_sine runs recorded off their force target

    def progress(name: str, doc: Any) -> None:
        if name == "start" and (doc.metadata or {}).get("force_converged") is False:
            unconverged.append(doc.name)
        if name == "stop":
            bar.total = max(bar.total, bar.done + 1)
            bar.advance(note=f"{getattr(doc, 'status', '')}")

    t0 = time.perf_counter()
    with terminate_as_interrupt(), open_rig(cfg) as rig:
        engine = rig.engine([writer, progress], calibration_sources=sources)
        with stop_on_signals(engine, (signal.SIGTERM, signal.SIGINT)) as received:
            result = engine.run(plan)       # a signal ends it 'aborted' at its next block
        if received.name is not None:
            raise KeyboardInterrupt(f"signal {received.name}")
    elapsed = time.perf_counter() - t0
    writer.retry_catalog()            # the catalog may be back after an outage mid-plan
    pending = {str(p): why for p, why in writer.catalog_pending.items()}
    paths = [str(out / f"{r.name}.h5") for r in result.runs if r.n_samples > 0]
    skipped: list[dict[str, str]] = []   # broadband records: no steady cycles to analyse
    rows = analyze_paths(paths, "loop", progress=False, errors=skipped) if paths else []
    status = {r.name: r.status for r in result.runs}
    for row in rows:
        row["status"] = status.get(row["run"], "")
    if args.json:
        emit_json({"status": result.status, "reason": result.reason, "data_dir": str(out),
                   "elapsed_s": elapsed, "runs": rows, "not_analysed": skipped,
                   "not_catalogued": pending, "force_not_converged": unconverged,
                   "calibrations": {c.name: [list(p) for p in c.calibration]
                                    for c in cfg.daq.channels if c.name in sources}})
    else:
        print_loop_table(rows)
        for e in skipped:
            print(terminal_safe(f"{Path(e['file']).name}: not analysed here ({e['error']})"))
        units = {c.name: c.unit for c in cfg.daq.channels}
        for name, pts in sources.items():
            print(f"{name}: stored calibration, " + ", ".join(
                f"{p['n_per_v']:.4g} {units[name]}/V at {p['frequency_hz']:g} Hz" for p in pts))
        print(f"\n{len(paths)} run files in {out} ({result.status}{': ' + result.reason if result.reason else ''}); "
              f"{elapsed:.1f} s")
    if pending:
        print(terminal_safe(
            f"warning: the catalog {writer.catalog.location} could not index {len(pending)} of "
            f"{len(result.runs)} run(s) ({next(iter(pending.values()))}); their files are "
            "complete: `labjoint recover` indexes them when the catalog is back"), file=sys.stderr)
    if unconverged:
        print(terminal_safe(f"warning: the force did not reach its target in {len(unconverged)} "
                            f"run(s): {', '.join(unconverged)}"), file=sys.stderr)
    return 0 if result.status == "complete" and not (pending or unconverged) else 1
