"""Simulated structural rig speed (seed 000's pipe assembly on a shaker): 60 s of simulated
time read in DAQ blocks, per joint law; ratio to real time. Light damping needs seconds of
simulated time per step-sine step, so this ratio is what a step-sine set costs.

Run: .venv/bin/python benchmarks/bench_structure_rig.py [--seconds 60]
Prints a human line per law and one JSON line.
"""

from __future__ import annotations

import argparse
import json
import time

from labjoint.config import CONFIG_DIR, load_config
from labjoint.hardware.sim import open_sim


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args()
    out = {}
    for law in ("iwan", "jenkins", "richard_abbott", "linear"):
        cfg = load_config(CONFIG_DIR / "rig-structure-sim.toml", {"sim": {"joint": {"law": law}}})
        gen, daq, rig = open_sim(cfg)
        gen.apply(28.0, 4.0)
        gen.set_output(True)
        daq.start()
        block = cfg.daq.block_samples
        daq.read(block)  # compile (or load the numba cache)
        fs = daq.sample_rate_hz
        n_blocks = int(round(args.seconds * fs / block))
        best = float("inf")
        for _ in range(3):  # best of three: the machine may be shared
            t = time.perf_counter()
            for _ in range(n_blocks):
                daq.read(block)
            best = min(best, time.perf_counter() - t)
        simulated = n_blocks * block / fs
        out[law] = simulated / best
        print(f"{law}: {simulated:.0f} s of {len(daq.channels)} channels at {fs:.0f} S/s "
              f"({rig.substeps} steps/sample, {rig.model.omega.size} modes) in {best:.3f} s: "
              f"{simulated / best:.0f}x real time")
        daq.close()
        gen.close()
    print(json.dumps({"benchmark": "structure_rig", "ratio_to_real_time": out, "simulated_s": args.seconds}))


if __name__ == "__main__":
    main()
