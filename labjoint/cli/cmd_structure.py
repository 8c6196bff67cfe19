"""`labjoint structure modes|update|frf STRUCTURE.toml`: the assembled-structure model (seed 000).

- modes: natural frequencies (Hz) and mode shapes at the sensors of the linear structure;
- update: stage-1 updating of the joint stiffness from measured natural frequencies;
- frf: the model's nonlinear FRF at constant force by harmonic balance and continuation;
- measured, ema: FRF sets from step-sine runs and their modal parameters
  (:mod:`labjoint.cli.cmd_structure_measured`).
"""

from __future__ import annotations

import argparse

import numpy as np

from labjoint.cli.cmd_structure_measured import add_measured_parsers, run_measured, run_ema
from labjoint.cli.cmd_structure_stage2 import add_stage2_parser, run_stage2
from labjoint.cli.structure_inputs import floats, load_with_sets
from labjoint.cli.output import emit_json, table
from labjoint.errors import InputError


def add_structure_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", metavar="ACTION")
    sub.required = True
    specs = {"modes": "natural frequencies and mode shapes of the linear structure",
             "update": "stage-1 updating of the joint stiffness from measured natural frequencies",
             "frf": "model FRF at constant force (harmonic balance + continuation)"}
    for name, help_ in specs.items():
        q = sub.add_parser(name, help=help_, description=help_)
        q.add_argument("structure", metavar="STRUCTURE.toml")
        q.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                       help="print one JSON object on stdout")
        q.add_argument("--set", action="append", default=[], metavar="PARAM=VALUE",
                       help="set a joint parameter first (E_e_pa or effect.param), e.g. E_e_pa=2.2e7")
        if name == "modes":
            q.add_argument("--count", type=int, default=6, help="number of modes (default 6)")
        if name == "update":
            q.add_argument("--measured-hz", required=True, help="measured natural frequencies, e.g. 28.5,177")
            q.add_argument("--parameter", default=None,
                           help="joint parameter(s) to update, comma-separated (default E_e_pa for a "
                                "seed-000 layer; E_e_pa,transverse_stiffness_n_per_m places two modes)")
        if name == "frf":
            q.add_argument("--force-n", type=float, required=True, help="force amplitude (N, peak)")
            q.add_argument("--band", required=True, help="frequency band START:END in Hz")
            q.add_argument("--harmonics", type=int, default=3, help="harmonics in the balance (default 3)")
            q.add_argument("--modes", type=int, default=10,
                           help="Craig-Bampton kept modes (default 10; -1: unreduced)")
            q.add_argument("--samples", type=int, default=None, help="AFT samples per period (default 256)")
    add_measured_parsers(sub)
    add_stage2_parser(sub)


def run(args: argparse.Namespace) -> int:
    return {"modes": _modes, "update": _update, "frf": _frf, "measured": run_measured,
            "ema": run_ema, "stage2": run_stage2}[args.action](args)


def _modes(args: argparse.Namespace) -> int:
    from labjoint.structure.modal import modes

    s = load_with_sets(args)
    if args.count < 1:
        raise InputError(f"must be >= 1, got {args.count}", field="--count")
    m = modes(s, args.count)
    shapes = {nm: (s.sensors[i] @ m.shapes).tolist() for i, nm in enumerate(s.sensor_names)}
    res = {"structure": s.name, "beam": s.theory, "dofs": s.n, "frequencies_hz": m.frequencies_hz.tolist(),
           "mode_shapes_at_sensors": shapes,
           "joints": [{"name": j.name, "type": j.geometry, "model": j.law.model.expr,
                       "rotational_stiffness_nm_per_rad": j.rotational_stiffness(),
                       "transverse_stiffness_n_per_m": j.transverse_stiffness} for j in s.joints]}
    if getattr(args, "json", False):
        emit_json(res)
        return 0
    print(table(["mode", "frequency Hz"], [(i + 1, f) for i, f in enumerate(m.frequencies_hz)]))
    return 0


def _update(args: argparse.Namespace) -> int:
    from labjoint.structure.modal import update_stiffness

    s = load_with_sets(args)
    r = update_stiffness(s, floats(args.measured_hz, "--measured-hz"), args.parameter)
    res = {"structure": s.name, **r.to_dict()}
    if getattr(args, "json", False):
        emit_json(res)
        return 0
    for k, v in (r.values or {r.parameter: r.value}).items():
        print(f"{k}: {(r.initials or {k: r.initial})[k]:.4g} -> {v:.4g}")
    print(f"{len(r.history)} iterations")
    print(table(["mode", "initial Hz", "updated Hz", "measured Hz"],
                zip(range(1, r.measured_hz.size + 1), r.initial_hz, r.updated_hz, r.measured_hz)))
    return 0


def _frf(args: argparse.Namespace) -> int:
    from labjoint.structure.frf import frf

    s = load_with_sets(args)
    band = floats(args.band, "--band", ":")
    if len(band) != 2:
        raise InputError(f"expected START:END in Hz, got '{args.band}'", field="--band")
    r = frf(s, args.force_n, (band[0], band[1]), harmonics=args.harmonics,
            modes=None if args.modes < 0 else args.modes, samples=args.samples)
    res = {"structure": s.name, **r.to_dict()}
    if getattr(args, "json", False):
        emit_json(res)
        return 0
    name = s.sensor_names[-1]
    acc = res["sensors"][name]["accelerance_m_s2_per_n"]
    i = int(np.argmax(acc))
    print(f"{res['points']} points, {args.force_n:g} N: peak {acc[i]:.4g} m/s^2/N at "
          f"{res['frequencies_hz'][i]:.4g} Hz ({name}); turning points: {res['turning_points_hz']}")
    return 0
