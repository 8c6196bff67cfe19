"""Benchmark: diagnose linear_stiffness+iwan over 12 runs (3 frequencies x 4 amplitudes,
40 steady cycles each, 25.6 kS/s) with every candidate effect, as wall time on this
machine (target <= 30 s), against the naive way (every candidate refitted from scratch with
the fitter's defaults, serially) in the same run; and the fit of linear_stiffness+iwan on
the same set (target <= 5 s).

Data: the simulated rig (Segalman Iwan joint with viscous damping hidden), DC-coupled NI
9234 channels at 25.6 kS/s, a flat joint-force sensor with 0.3 N rms noise, each level
settled for 0.3 s before its 40 recorded cycles (what a dwell plan records).
Run: ``python -m benchmarks.bench_diagnose`` (or ``python benchmarks/bench_diagnose.py``).
"""

from __future__ import annotations

import time

import numpy as np

from labjoint.compare import DiagnoseSettings, diagnose_prepared, prepare_runs
from labjoint.compare.runs import default_split
from labjoint.hardware.interfaces import ChannelSpec, GeneratorSettings
from labjoint.hardware.sim import SimConfig, SimRig
from labjoint.models import ModelFitter
from labjoint.storage import Run

FS = 25600.0
CYCLES = 40
LEVELS = {300.0: (2.0, 3.5, 5.0, 7.0), 400.0: (4.0, 7.0, 11.0, 15.0), 600.0: (5.0, 9.0, 13.0, 18.0)}
JOINT = {"family": "iwan", "F_S": 120.0, "K_T": 14e6, "chi": -0.5, "beta": 0.3}
HIDDEN = [{"name": "viscous", "c": 300.0}]
MODEL = "linear_stiffness+iwan"
TARGET_DIAGNOSE_S, TARGET_FIT_S = 30.0, 5.0


def make_runs() -> list[Run]:
    """12 steady runs of the simulated rig, in SI units."""
    chans = [ChannelSpec("disp_1", "capacitive", "displacement", "m", 1.25e-5, coupling="DC"),
             ChannelSpec("disp_2", "capacitive", "displacement", "m", 1.25e-5, coupling="DC"),
             ChannelSpec("shear_nc", "force", "force", "N", 50.0, coupling="DC")]
    cfg = SimConfig.from_dict({"joint": JOINT, "effects": HIDDEN, "module_name": "NI 9234",
                               "sensors": {"force_noise_n": 0.3}})
    runs = []
    for f, levels in LEVELS.items():
        for v in levels:
            rig = SimRig(cfg, chans, FS)
            on = GeneratorSettings(f, v, 0.0, True)
            rig.advance(int(0.3 * FS), on)
            volts = rig.advance(int(round(CYCLES * FS / f)) + 8, on)
            u = (volts[0] - volts[1]) * 1.25e-5
            runs.append(Run(f"b{f:g}Hz_{v:g}Vpp", np.arange(u.size) / FS, u, volts[2] * 50.0,
                            {"frequency_hz": f, "sample_rate_hz": FS}))
    return runs


def main() -> None:
    runs = prepare_runs(make_runs())
    n = sum(len(r.data.force) for r in runs)
    warm_up = prepare_runs(make_runs()[:3])
    diagnose_prepared(warm_up, MODEL, validate=[warm_up[1].name])      # JIT and cache warm-up
    fit_r, _, _ = default_split(runs)

    t0 = time.perf_counter()
    fit = ModelFitter(MODEL).fit([r.data for r in runs])
    t_fit = time.perf_counter() - t0

    t0 = time.perf_counter()
    warm = diagnose_prepared(runs, MODEL)
    t_warm = time.perf_counter() - t0

    t0 = time.perf_counter()
    naive = diagnose_prepared(runs, MODEL, settings=DiagnoseSettings(warm=False, refine=0))
    t_naive = time.perf_counter() - t0

    print(f"data: {len(runs)} runs, {n} samples, {sum(r.n_cycles for r in runs)} steady cycles; "
          f"fit on {len(fit_r)} runs, candidates: {len(warm.candidates)}")
    print(f"fit {MODEL}: {t_fit:.2f} s (target {TARGET_FIT_S:g} s, ratio {t_fit / TARGET_FIT_S:.2f}), "
          f"NRMSE {fit.nrmse_:.4f}")
    print(f"diagnose (warm, staged, 2 processes): {t_warm:.2f} s (target {TARGET_DIAGNOSE_S:g} s, "
          f"ratio {t_warm / TARGET_DIAGNOSE_S:.2f}); {warm.timing_s}")
    print(f"diagnose (naive: from scratch, serial): {t_naive:.2f} s; naive / warm = "
          f"{t_naive / t_warm:.2f}")
    for name, d in (("warm", warm), ("naive", naive)):
        top = d.candidates[0]
        print(f"  {name:5s}: best {top.effect} (validation NRMSE {top.nrmse_after_validation:.4f}, "
              f"noise floor {d.noise_floor_validation:.4f}); verdict: {d.verdict[:70]}")


if __name__ == "__main__":
    main()
