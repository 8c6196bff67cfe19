"""`labjoint predict MODEL.json RECORD`: simulate a saved model on a record's force and
compare the predicted displacement with the measured one."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from labjoint.cli.output import emit_json


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
                   help="write time_s, displacement_m (measured), predicted_m")


def run(args: argparse.Namespace) -> int:
    from labjoint.compare.output_error import predict_file

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

