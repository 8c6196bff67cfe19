"""Benchmark: diagnose linear_stiffness+iwan over 12 runs (3 frequencies x 4 amplitudes,
40 steady cycles each, 25.6 kS/s) with every candidate effect, as wall time on this
machine (target <= 30 s), against the naive way (every candidate refitted from scratch with
the fitter's defaults, serially) in the same run; and the fit of linear_stiffness+iwan on
the same set (target <= 5 s).

Data: the simulated rig (Segalman Iwan joint with viscous damping hidden), DC-coupled NI
9234 channels at 25.6 kS/s, a flat joint-force sensor with 0.3 N rms noise, each level
settled for 0.3 s before its 40 recorded cycles (what a dwell plan records).
Figures: diagnose's wall time (median of repeats) as a ratio to the naive serial refit's
(measured once, between them) and to the 30 s target; the fit's to the 5 s target.
Run: ``python -m benchmarks.bench_diagnose [--smoke] [--repeats N]`` (or ``python benchmarks/bench_diagnose.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.compare import DiagnoseSettings, diagnose_prepared, prepare_runs  # noqa: E402
from labjoint.compare.runs import default_split  # noqa: E402
from labjoint.hardware.interfaces import ChannelSpec, GeneratorSettings  # noqa: E402
from labjoint.hardware.sim import SimConfig, SimRig  # noqa: E402
from labjoint.models import ModelFitter  # noqa: E402
from labjoint.storage import Run  # noqa: E402

FS = 25600.0
CYCLES = 40
LEVELS = {300.0: (2.0, 3.5, 5.0, 7.0), 400.0: (4.0, 7.0, 11.0, 15.0), 600.0: (5.0, 9.0, 13.0, 18.0)}
JOINT = {"family": "iwan", "F_S": 120.0, "K_T": 14e6, "chi": -0.5, "beta": 0.3}
HIDDEN = [{"name": "viscous", "c": 300.0}]
MODEL = "linear_stiffness+iwan"
TARGET_DIAGNOSE_S, TARGET_FIT_S = 30.0, 5.0


def make_runs(levels: dict = LEVELS, cycles: int = CYCLES, settle_s: float = 0.3) -> list[Run]:
    """12 steady runs of the simulated rig, in SI units."""
    chans = [ChannelSpec("disp_1", "capacitive", "displacement", "m", 1.25e-5, coupling="DC"),
             ChannelSpec("disp_2", "capacitive", "displacement", "m", 1.25e-5, coupling="DC"),
             ChannelSpec("shear_nc", "force", "force", "N", 50.0, coupling="DC")]
    cfg = SimConfig.from_dict({"joint": JOINT, "effects": HIDDEN, "module_name": "NI 9234",
                               "sensors": {"force_noise_n": 0.3}})
    runs = []
    for f, amps in levels.items():
        for v in amps:
            rig = SimRig(cfg, chans, FS)
            on = GeneratorSettings(f, v, 0.0, True)
            rig.advance(int(settle_s * FS), on)
            volts = rig.advance(int(round(cycles * FS / f)) + 8, on)
            u = (volts[0] - volts[1]) * 1.25e-5
            runs.append(Run(f"b{f:g}Hz_{v:g}Vpp", np.arange(u.size) / FS, u, volts[2] * 50.0,
                            {"frequency_hz": f, "sample_rate_hz": FS}))
    return runs


def main() -> None:
    ap = parser(__doc__)
    args = ap.parse_args()
    bench = Bench.from_args("diagnose", args, repeats=3)
    only = None
    if args.smoke:           # 4 short runs, 2 candidates, one repeat: the code path only
        raw = make_runs({400.0: (4.0, 7.0, 11.0, 15.0)}, cycles=12, settle_s=0.1)
        only, bench.repeats = ("viscous", "cubic_stiffness"), 1
    else:
        raw = make_runs()
    runs = prepare_runs(raw)
    n = sum(len(r.data.force) for r in runs)
    warm_up = prepare_runs(raw[:3])
    bench.warm_up(lambda: diagnose_prepared(warm_up, MODEL, validate=[warm_up[1].name],
                                            settings=DiagnoseSettings(candidates=only)),
                  "diagnose of 3 runs")
    fit_r, _, _ = default_split(runs)

    t_fit = bench.repeat(lambda: ModelFitter(MODEL).fit([r.data for r in runs]))
    fit = t_fit.result
    t_warm = bench.repeat(lambda: diagnose_prepared(
        runs, MODEL, settings=DiagnoseSettings(candidates=only)))
    warm = t_warm.result
    t_naive = bench.repeat(lambda: diagnose_prepared(
        runs, MODEL, settings=DiagnoseSettings(warm=False, refine=0, candidates=only)), 1)
    naive = t_naive.result

    print(f"data: {len(runs)} runs, {n} samples, {sum(r.n_cycles for r in runs)} steady cycles; "
          f"fit on {len(fit_r)} runs, candidates: {len(warm.candidates)}; fit NRMSE "
          f"{fit.nrmse_:.4f}; diagnose stages {warm.timing_s}")
    bench.figure("fit wall / target", t_fit.median / TARGET_FIT_S,
                 f"the {TARGET_FIT_S:g} s target", value=t_fit.median, unit="s",
                 target="<= 1", timing=t_fit)
    bench.figure("diagnose wall / target", t_warm.median / TARGET_DIAGNOSE_S,
                 f"the {TARGET_DIAGNOSE_S:g} s target", value=t_warm.median, unit="s",
                 target="<= 1", timing=t_warm)
    bench.figure("naive serial refit / diagnose", t_naive.median / t_warm.median,
                 "diagnose (warm, staged): the naive way is this many times slower",
                 value=t_naive.median, unit="s (naive, one run)")
    for name, d in (("warm", warm), ("naive", naive)):
        top = d.candidates[0]
        print(f"  {name:5s}: best {top.effect} (validation NRMSE {top.nrmse_after_validation:.4f}, "
              f"noise floor {d.noise_floor_validation:.4f}); verdict: {d.verdict[:70]}")
    bench.finish(runs=len(runs), samples=n, best_candidate=warm.candidates[0].effect)


if __name__ == "__main__":
    main()
