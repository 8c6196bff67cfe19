"""`labjoint structure stage2 STRUCTURE.toml FRF.json...`: stage-2 updating of the joint
law's nonlinear parameters on measured FRFs (seed 000 Eq. 9; fitted around mode 1,
validated around mode 2), with standard errors (:func:`labjoint.structure.stage2.update_nonlinear`)."""

from __future__ import annotations

import argparse
from typing import Any

from labjoint.cli.output import emit_json, table
from labjoint.errors import InputError


def add_stage2_parser(sub: Any) -> None:
    """The ``stage2`` action of ``labjoint structure``."""
    h = "stage-2 updating of the joint's nonlinear parameters on FRF sets (seed 000 Eq. 9)"
    q = sub.add_parser("stage2", help=h, description=h)
    q.add_argument("structure", metavar="STRUCTURE.toml")
    q.add_argument("frf", nargs="+", metavar="FRF.json", help="FRF set files (structure measured)")
    q.add_argument("--law-params", default=None, metavar="P,...",
                   help="law parameters to fit, short (kp,F_y,n) or full (richard_abbott.kp) "
                        "names (default: E_p, S_Y, n of a Richard-Abbott joint, else all but ke)")
    q.add_argument("--set", action="append", default=[], metavar="PARAM=VALUE",
                   help="set a joint parameter first (the start of the fit), e.g. richard_abbott.n=3")
    q.add_argument("--modes", type=int, default=10, help="Craig-Bampton kept modes (default 10)")
    q.add_argument("--max-evals", type=int, default=None, help="largest number of model evaluations")
    q.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON object")


def law_parameters(text: str | None, known: list[str]) -> list[str] | None:
    """Full names of ``text``'s comma-separated parameters among ``known`` (None: default).

    >>> law_parameters("kp, n", ["richard_abbott.ke", "richard_abbott.kp", "richard_abbott.n"])
    ['richard_abbott.kp', 'richard_abbott.n']
    """
    if text is None:
        return None
    out = []
    for p in (x.strip() for x in text.split(",")):
        if not p:
            continue
        hits = [k for k in known if k == p or k.split(".", 1)[-1] == p]
        if len(hits) != 1:
            why = "is ambiguous" if hits else "is not a parameter of the joint law"
            raise InputError(f"{p} {why} ({', '.join(known) or 'no joint'})", field="--law-params")
        out.append(hits[0])
    if not out:
        raise InputError("names no parameter", field="--law-params")
    return out


def run_stage2(args: argparse.Namespace) -> int:
    from labjoint.cli.structure_inputs import load_with_sets
    from labjoint.signal.frfset import FrfSet, concat
    from labjoint.structure.predict import FrfPredictor
    from labjoint.structure.stage2 import update_nonlinear

    if args.modes < 0:
        raise InputError(f"must be >= 0, got {args.modes}", field="--modes")
    s = load_with_sets(args)
    if not s.joints:
        raise InputError("the structure has no joint", field="joints")
    names = law_parameters(args.law_params, list(s.joints[0].law.params))
    fs = concat([FrfSet.load(f) for f in args.frf])
    r = update_nonlinear(FrfPredictor(s, args.modes, harmonics=1), fs, names, max_nfev=args.max_evals)
    d = {"structure": s.name, "frf": list(map(str, args.frf)), "law": s.joints[0].law.model.expr,
         **r.to_dict()}
    if getattr(args, "json", False):
        emit_json(d)
        return 0
    print(table(["parameter", "value", "stderr"],
                [(k, v["value"], v["stderr"]) for k, v in d["parameters"].items()]))
    if not d["converged"]:
        print(f"not converged: {'; '.join(d['flags'])} (standard errors not given)")
    val = d["error_validation_rms"]
    print(f"Eq. 9 RMS error: fit {d['error_fit_rms']:.4g} ({d['fit_steps']} steps around mode 1), "
          f"validation {'-' if val is None else f'{val:.4g}'} ({d['validation_steps']} steps)")
    return 0
