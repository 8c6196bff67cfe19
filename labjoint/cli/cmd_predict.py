"""`labjoint predict MODEL.json RECORD`: simulate a saved model on a record's force and
compare the predicted displacement with the measured one."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from labjoint.cli.output import emit_json
from labjoint.errors import InputError


def add_predict_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("model", metavar="MODEL.json", help="a model saved by `labjoint fit --error "
                                                       "simulation --out`")
    p.add_argument("record", metavar="RECORD", help="HDF5 run file or CSV (force_N in, "
                                                     "displacement_m out)")
    p.add_argument("--periodic", action="store_true",
                   help="the record is one period of a steady periodic input: simulate until "
                        "the response is periodic, compare about the mean")
    p.add_argument("--warmup", default="auto", metavar="SECONDS",
                   help="seconds of the record left unjudged at its start (default auto: until "
                        "the displacement has reached both its extremes, or none when the "
                        "record starts at rest)")
    p.add_argument("--out", default=None, metavar="PRED.csv",
                   help="write time_s, displacement_m (measured), predicted_m (a modal model: "
                        "each channel measured and model)")
    p.add_argument("--shaker", default=None, metavar="S.toml",
                   help="the record is driven by a voltage: drive the model through the shaker of "
                        "this file's [shaker] table (SI) and predict the response per volt in its "
                        "quantity and the force on the structure")
    p.add_argument("--response", default=None, metavar="NAME",
                   help="with --shaker: the response channel (default: the first motion channel)")
    p.add_argument("--full", action="store_true",
                   help="a modal model with --json: the measured and model series too")


def _modal(args: argparse.Namespace) -> int:
    """A saved modal model on a record: the responses in their measured quantities."""
    from labjoint.compare.modal_api import predict_modal

    if args.periodic:
        raise InputError("--periodic goes with a joint model, not a modal one", field="periodic")
    res = predict_modal(args.model, args.record)
    if args.out:
        out = Path(args.out)
        tmp = out.with_name(out.name + ".tmp")
        chans = res["channels"]
        cols = [np.asarray(v[k]) for v in chans.values() for k in ("measured", "model")]
        n = cols[0].size
        head = ",".join(["time_s"] + [f"{c}_{k}" for c in chans for k in ("measured", "model")])
        np.savetxt(tmp, np.column_stack([np.arange(n) / res["sample_rate_hz"], *cols]), delimiter=",",
                   header=head, comments="", fmt="%.9g")
        tmp.replace(out)
    full = getattr(args, "json", False) and getattr(args, "full", False)
    res["saved"] = args.out
    if not full:
        for v in res["channels"].values():
            v.pop("measured"), v.pop("model")
        res.pop("force_on_structure_n", None)
    if args.json:
        emit_json(res)
        return 0
    for ch, v in res["channels"].items():
        print(f"{ch} ({v['quantity']}): NRMSE {100 * v['nrmse']:.3g} %")
    print(f"pooled NRMSE {100 * res['nrmse']:.3g} %")
    if "force_rms_n" in res:
        print(f"through the shaker: force on the structure {res['force_rms_n']:.4g} N rms")
        fu = res.get("fundamental")
        if fu and "force_per_volt" in fu:
            print(f"at {fu['frequency_hz']:.4g} Hz: force per volt {fu['force_per_volt']['amplitude']:.4g} N/V "
                  f"({fu['force_per_volt']['phase_deg']:.3g} deg)")
        for ch, v in (fu or {}).get("channels", {}).items():
            pn = v["per_newton"]
            pv = v.get("per_volt")
            print(f"  {ch}: " + (f"per volt {pv['amplitude']:.4g} ({pv['phase_deg']:.3g} deg), " if pv else "")
                  + f"per newton {pn['amplitude']:.4g} ({pn['phase_deg']:.3g} deg)")
    return 0


def _shaker(args: argparse.Namespace) -> int:
    """A joint model through the shaker on a voltage-driven record: response and force."""
    from labjoint.compare.shaker_predict import predict_shaker

    if args.periodic:
        raise InputError("--periodic goes without --shaker", field="periodic")
    res = predict_shaker(args.model, args.record, args.shaker, warmup=args.warmup, response=args.response)
    if args.out:
        out = Path(args.out)
        tmp = out.with_name(out.name + ".tmp")
        chans = res["channels"]
        cols = [np.asarray(v[k]) for v in chans.values() for k in ("measured", "model") if v[k] is not None]
        head = ",".join(["time_s"] + [f"{c}_{k}" for c, v in chans.items() for k in ("measured", "model")
                                      if v[k] is not None])
        n = cols[0].size
        np.savetxt(tmp, np.column_stack([res["warmup_s"] + np.arange(n) / res["sample_rate_hz"], *cols]),
                   delimiter=",", header=head, comments="", fmt="%.9g")
        tmp.replace(out)
    res["saved"] = args.out
    if not (getattr(args, "json", False) and args.full):
        for v in res["channels"].values():
            v.pop("measured"), v.pop("model")
    if args.json:
        emit_json(res)
        return 0
    for ch, v in res["channels"].items():
        nr = "not measured" if v["nrmse"] is None else f"NRMSE {100 * v['nrmse']:.3g} %"
        print(f"{ch} ({v['quantity']}): {nr}")
    return 0


def run(args: argparse.Namespace) -> int:
    from labjoint.compare.modal_api import is_modal_model
    from labjoint.compare.model_file import predict_file

    if args.shaker:
        if is_modal_model(args.model):
            raise InputError("--shaker goes with a joint model file; the modal model holds the shaker "
                             "path as modal.drive and its high-pass", field="shaker")
        return _shaker(args)
    if args.response:
        raise InputError("--response goes with --shaker", field="response")
    if is_modal_model(args.model):
        return _modal(args)
    pred = predict_file(args.model, args.record, periodic=args.periodic, warmup=args.warmup)
    if args.out:
        out = Path(args.out)
        tmp = out.with_name(out.name + ".tmp")
        n = pred.predicted.size
        data = np.column_stack([np.arange(n) / pred.fs, pred.measured, pred.predicted])
        np.savetxt(tmp, data, delimiter=",", header="time_s,displacement_m,predicted_m",
                   comments="", fmt="%.9g")
        tmp.replace(out)
    res = {"model": str(args.model), "record": str(args.record), "periodic": args.periodic,
           "rmse": pred.rmse, "nrmse": pred.nrmse, "noise_std_m": pred.noise_std_m,
           "samples": int(pred.judged.sum()), "warmup": args.warmup, "saved": args.out}
    if args.json:
        emit_json(res)
        return 0
    print(f"{pred.name}: RMSE {pred.rmse:.4g} m, NRMSE {100 * pred.nrmse:.3g} % over "
          f"{res['samples']} samples (displacement noise {pred.noise_std_m:.3g} m)")
    return 0

