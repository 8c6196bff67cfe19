"""`labjoint fit|diagnose|ladder RUN... --model EXPR`: model comparison on the command line.

RUN is an HDF5 run file or a CSV file in the import format (design.md), or an FRF set
file (JSON, format ``labjoint.frfset/1``) compared inside ``--structure STRUCTURE.toml``
(the ``frf`` kind: the joint model in the structure's joints), or a backbone file (JSON,
``labjoint.backbone/1``, written by ``labjoint backbone --out``) inside the same structure
(the ``backbone`` kind), alone or beside FRF sets in one comparison. With ``--json``
each prints the JSON object of the model-comparison contract; without it, the same as
readable tables.
"""

from __future__ import annotations

import argparse
from typing import Any

from labjoint.cli.limits import plausibility, print_flags
from labjoint.cli.modal_args import add_modal_arguments, modal_options
from labjoint.cli.output import Progress, emit_json, fmt, table
from labjoint.errors import InputError


def _pct(x: Any) -> str:
    return "-" if x is None else f"{100 * float(x):.3g} %"


def _x100(x: Any) -> float | None:
    return None if x is None else 100.0 * float(x)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", nargs="+", metavar="RUN",
                   help="HDF5 run files or CSV files (import format), or FRF set and backbone files (JSON)")
    p.add_argument("--model", required=True, metavar="EXPR",
                   help="effects joined by '+', e.g. linear_stiffness+iwan")
    p.add_argument("--validate", nargs="+", metavar="RUN", default=None,
                   help="runs to validate on (names or files); default: hold out the highest "
                        "frequency, or every 3rd run by amplitude with one frequency")
    p.add_argument("--prime-cycles", default="auto",
                   help="cycles of priming for records that start in steady state ('auto')")
    p.add_argument("--seed", type=int, default=0, help="seed of the fitter's extra starts")
    p.add_argument("--structure", default=None, metavar="STRUCTURE.toml",
                   help="FRF sets and backbones: the structure whose joints carry the model")
    p.add_argument("--modes", type=int, default=None, metavar="N",
                   help="FRF sets: Craig-Bampton kept modes (default 10)")
    p.add_argument("--harmonics", type=int, default=None, metavar="H",
                   help="FRF sets: response harmonics compared (default the set's, at most 3)")
    p.add_argument("--linear-damping", default=None, choices=("file", "measured"),
                   help="backbones: the structure's linear damping from its file (default) or "
                        "identified from the backbones' low-amplitude linear range")
    add_modal_arguments(p)
    p.add_argument("--max-displacement", type=float, default=None, metavar="M",
                   help="largest plausible displacement amplitude (m) of a steady sine (default "
                        "the rig config's [plausibility] max_displacement_amplitude_m, else 0.01 m: "
                        "a joint's; a structure's may be larger); checked before the fit")
    p.add_argument("--kind", choices=("auto", "sine", "record", "frf", "modal"), default="auto",
                   help="judge steady-sine cycles (sine) or the record along its history under "
                        "any excitation (record); auto: sine when every run is a steady sine")
    p.add_argument("--warmup", default="auto", metavar="S",
                   help="record kind: seconds left unjudged at the start (auto: until the "
                        "displacement has reached both its extremes)")


def _judging(p: argparse.ArgumentParser) -> None:
    p.add_argument("--factor", type=float, default=1.5,
                   help="adequate when NRMSE <= factor x noise floor (default 1.5)")
    p.add_argument("--alpha", type=float, default=0.01, help="significance level (default 0.01)")
    p.add_argument("--jobs", type=int, default=None, help="candidate refits in parallel (default 2)")
    p.add_argument("--candidates", default=None, metavar="A,B,...",
                   help="only try these effects (default: every effect not in the model)")


def _error(p: argparse.ArgumentParser) -> None:
    p.add_argument("--error", choices=("equation", "simulation"), default="equation",
                   help="equation: the force balance along the measured displacement (any "
                        "kind); simulation: the displacement simulated from the applied force "
                        "(output error; the model needs inertia)")
    p.add_argument("--periodic", action="store_true",
                   help="with --error simulation: each record is whole periods of a steady "
                        "periodic input; simulate to its steady state")
    p.add_argument("--start", action="append", default=None, metavar="NAME=VALUE",
                   help="with --error simulation or --modal: start the search here (SI units, "
                        "e.g. inertia.m=0.05, shaker.highpass_hz=1.5); repeat or join by commas")
    p.add_argument("--bound", action="append", default=None, metavar="NAME=LO:HI",
                   help="with --error simulation or --modal: keep a parameter within LO:HI (SI "
                        "units; LO = HI holds it, e.g. shaker.highpass_hz=0:0 for no high-pass)")


def _pairs(items: list[str] | None, flag: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for item in items or []:
        for part in item.split(","):
            if not part.strip():
                continue
            name, eq, value = part.partition("=")
            if not eq or not name.strip() or not value.strip():
                raise InputError(f"expected NAME=VALUE, got {part!r}", field=flag)
            out[name.strip()] = value.strip()
    return out


def _number(text: str, field: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise InputError(f"not a number: {text!r}", field=field) from None
    if x != x or x in (float("inf"), float("-inf")):
        raise InputError(f"not a finite number: {text!r}", field=field)
    return x


def start_and_bounds(args: argparse.Namespace) -> tuple[dict[str, float], dict[str, tuple[float, float]]]:
    """``--start`` and ``--bound`` as {name: value} and {name: (lo, hi)}."""
    start = {k: _number(v, f"start.{k}") for k, v in _pairs(args.start, "start").items()}
    bounds = {}
    for k, v in _pairs(args.bound, "bound").items():
        lo, colon, hi = v.partition(":")
        if not colon:
            raise InputError(f"expected LO:HI, got {v!r}", field=f"bound.{k}")
        bounds[k] = (_number(lo, f"bound.{k}") if lo.strip() else float("-inf"),
                     _number(hi, f"bound.{k}") if hi.strip() else float("inf"))
    return start, bounds


def add_fit_arguments(p: argparse.ArgumentParser) -> None:
    _common(p)
    _error(p)
    p.add_argument("--out", default=None, metavar="MODEL.json",
                   help="with --error simulation: save the identified model")


def add_diagnose_arguments(p: argparse.ArgumentParser) -> None:
    _common(p)
    _judging(p)
    _error(p)


def add_ladder_arguments(p: argparse.ArgumentParser) -> None:
    _common(p)
    _judging(p)
    _error(p)
    p.add_argument("--max-steps", type=int, default=None, metavar="N",
                   help="add at most N effects (default: until adequate)")
    p.add_argument("--manual", action="store_true",
                   help="no search: the steps are the prefixes of --model")
    p.add_argument("--no-save", action="store_true", help="do not save the ladder in the run files")


def _prime(v: str) -> int | str:
    return v if v == "auto" else int(v)


def _options(args: argparse.Namespace, judging: bool) -> dict[str, Any]:
    o: dict[str, Any] = {"validate": args.validate, "prime_cycles": _prime(args.prime_cycles),
                         "seed": args.seed, "kind": args.kind, "warmup": args.warmup,
                         "structure": args.structure, "modes": args.modes,
                         "harmonics": args.harmonics, "modal": args.modal,
                         "linear_damping": args.linear_damping,
                         "responses": args.responses, "between": args.between,
                         "plausibility": plausibility(args)}
    o.update(modal_options(args, *start_and_bounds(args)))
    if judging:
        o.update(factor=args.factor, alpha=args.alpha, n_jobs=args.jobs,
                 candidates=args.candidates)
    return o


def _progress(args: argparse.Namespace, label: str, total: int) -> Any:
    bar = Progress(total, label, enabled=not args.quiet)
    return lambda note: bar.advance(1, note)


def fit(args: argparse.Namespace) -> int:
    from labjoint.compare import fit_runs

    if args.error == "simulation":
        return _fit_simulation(args)
    if args.out and not args.modal:
        raise InputError("--out goes with --error simulation or --modal", field="error")
    _simulation_only(args)
    if args.modal:
        return _fit_modal(args)
    res = fit_runs(args.runs, args.model, **_options(args, False))
    if args.json:
        emit_json(res)
        return 0
    print(f"model {res['model']}: NRMSE {_pct(res['nrmse'])}, noise floor {_pct(res['noise_floor'])}")
    _print_parameters(res)
    print()
    print(table(["run", "NRMSE %", "energy loss err %", "stiffness err %"],
                [[r["run"], _x100(r["nrmse"]), r["energy_loss_error_pct"], r["stiffness_error_pct"]]
                 for r in res["runs"]]))
    return 0


def _fit_modal(args: argparse.Namespace) -> int:
    """A modal fit (simulation error of the responses), saved with --out when finite."""
    from labjoint.compare.api import _measured, fit_report
    from labjoint.compare.jsonsafe import clean
    from labjoint.compare.modal_api import save_modal

    report = fit_report(args.runs, args.model, **_options(args, False))
    if args.out:
        save_modal(report.fit, report.evaluation.runs_measured(), args.out)
    res = clean(_measured(report.to_dict(), report.evaluation.runs_measured()))
    res["saved"] = args.out
    if args.json:
        emit_json(res)
        return 0
    print(f"model {res['model']} on mode 1: NRMSE {_pct(res['nrmse'])}, noise floor "
          f"{_pct(res['noise_floor'])}")
    print(f"drive: {res.get('drive_path')}")
    _print_parameters(res)
    print()
    print(table(["run", "NRMSE %"], [[r["run"], _x100(r["nrmse"])] for r in res["runs"]]))
    if args.out:
        print(f"saved to {args.out}")
    return 0


def _print_parameters(res: dict[str, Any]) -> None:
    """The parameter table, then each flagged parameter and each even effect's asymmetry."""
    print(table(["parameter", "value", "stderr", "unit"],
                [[k, v["value"], v["stderr"], v["unit"]] for k, v in res["parameters"].items()]))
    print_flags(res)
    for k, why in (res.get("flags") or {}).items():
        print(f"warning: {k}: {why}")
    for a in res.get("asymmetry") or []:
        print(f"asymmetry: {a['text']}")


def _not_modal(args: argparse.Namespace) -> None:
    modal_options(args, {}, {})
    if args.modal:
        raise InputError("--modal is judged by simulation error of the responses already; leave "
                         "out --error simulation", field="error")


def _fit_simulation(args: argparse.Namespace) -> int:
    from labjoint.compare.model_file import save_model
    from labjoint.compare.output_error import fit_simulation

    _not_modal(args)
    if args.structure:
        raise InputError("--error simulation judges records; FRF sets with --structure are "
                         "judged on their FRF residual", field="structure")
    start, bounds = start_and_bounds(args)
    fit = fit_simulation(args.runs, args.model, validate=args.validate, periodic=args.periodic,
                         warmup=args.warmup, seed=args.seed, start=start, bounds=bounds)
    if args.out:
        save_model(fit, args.out)
    res = fit.to_dict()
    res["saved"] = args.out
    if args.json:
        emit_json(res)
        return 0
    print(f"model {res['model']} by simulation error: RMSE {res['rmse']:.4g} m, NRMSE "
          f"{_pct(res['nrmse'])}, noise floor {_pct(res['noise_floor'])}")
    _print_parameters(res)
    for w in res["warnings"]:
        print(f"warning: {w}")
    if args.out:
        print(f"saved to {args.out}")
    return 0


def _simulation_job(args: argparse.Namespace, operation: str, steps: int) -> dict[str, Any]:
    """Diagnose or ladder by simulation error through the one option mapping REST uses."""
    from labjoint.compare.simulation_api import simulation_job

    _not_modal(args)
    if args.kind == "sine" or args.structure:
        raise InputError("--error simulation judges records (--kind record or auto; FRF sets "
                         "with --structure are judged on their FRF residual)", field="kind")
    start, bounds = start_and_bounds(args)
    options = {"validate": args.validate, "periodic": args.periodic, "warmup": args.warmup,
               "seed": args.seed, "factor": args.factor, "alpha": args.alpha,
               "candidates": args.candidates, "start": start or None, "bounds": bounds or None}
    return simulation_job(operation, args.runs, args.model, options,
                          max_steps=getattr(args, "max_steps", None),
                          progress=_progress(args, operation, steps))


def _simulation_only(args: argparse.Namespace) -> None:
    given = [f for f, v in (("periodic", args.periodic), ("start", args.start),
                            ("bound", args.bound)) if v and not (args.modal and f != "periodic")]
    if given:
        raise InputError(f"--{given[0]} goes with --error simulation"
                         + (" or --modal" if given[0] != "periodic" else ""), field=given[0])


def diagnose(args: argparse.Namespace) -> int:
    from labjoint.compare import diagnose_runs

    if args.error == "simulation":
        return _diagnose_simulation(args)
    _simulation_only(args)
    res = diagnose_runs(args.runs, args.model, **_options(args, True),
                        progress=_progress(args, "diagnose", 14))
    if args.json:
        emit_json(res)
        return 0
    _print_diagnosis(res, "")
    for c in res["candidates"][:3]:
        print(f"\n{c['effect']}: {c['evidence']}")
        if "tie" in c:
            print(f"  tie: {c['tie']['reason']}")
    return 0


def _diagnose_simulation(args: argparse.Namespace) -> int:
    res = _simulation_job(args, "diagnose", 8)
    if args.json:
        emit_json(res)
        return 0
    _print_diagnosis(res, " by simulation error")
    return 0


def _print_diagnosis(res: dict[str, Any], how: str) -> None:
    print(f"model {res['model']}{how}: NRMSE {_pct(res['nrmse'])}, noise floor "
          f"{_pct(res['noise_floor'])}, adequate: {'yes' if res['adequate'] else 'no'}")
    print(res["verdict"])
    print_flags(res)
    for k, why in (res.get("flags") or {}).items():
        print(f"warning: {k}: {why}")
    for a in res.get("asymmetry") or []:
        print(f"asymmetry: {a['text']}")
    print("\nwhere it fails:")
    for f in res["failures"]:
        print(f"  [{f['where']}] {f['text']}")
    print()
    print(table(["effect", "NRMSE after %", "validation %", "significant", "p"],
                [[c["effect"], _x100(c["nrmse_after"]), _x100(c["nrmse_after_validation"]),
                  "yes" if c["significant"] else "no", fmt(c["p_value"], 2)]
                 for c in res["candidates"]]))


def _ladder_simulation(args: argparse.Namespace) -> int:
    res = _simulation_job(args, "ladder", 8 * (args.max_steps or 3))
    if args.json:
        emit_json(res)
        return 0
    _print_ladder(res, "by simulation error; ")
    return 0


def _print_ladder(res: dict[str, Any], how: str) -> None:
    print(table(["step", "model", "added", "NRMSE %", "validation %", "adequate"],
                [[i, s["model"], s["added"] or "-", _x100(s["nrmse"]), _x100(s["nrmse_validation"]),
                  "yes" if s["adequate"] else "no"] for i, s in enumerate(res["steps"])]))
    print_flags(res)
    print(f"\n{how}noise floor {_pct(res['noise_floor'])}; adequate: "
          f"{'yes' if res['adequate'] else 'no'} ({res['stop_reason']})")


def ladder(args: argparse.Namespace) -> int:
    from labjoint.compare import ladder_runs

    if args.error == "simulation":
        if args.manual:
            raise InputError("--manual goes with --error equation", field="manual")
        return _ladder_simulation(args)
    _simulation_only(args)
    res = ladder_runs(args.runs, args.model, max_steps=args.max_steps, auto=not args.manual,
                      save=not args.no_save, **_options(args, True),
                      progress=_progress(args, "ladder", 14 * (args.max_steps or 3)))
    if args.json:
        emit_json(res)
        return 0
    _print_ladder(res, "")
    if res.get("saved"):
        print(f"saved as processed group model_ladder_{res['key']} in {len(res['saved'])} run file(s)")
    return 0
