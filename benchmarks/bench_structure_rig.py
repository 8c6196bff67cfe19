"""Simulated structural rig speed (seed 000's pipe assembly on a shaker): 60 s of simulated
time read in DAQ blocks, per joint law (iwan the continuous density, iwan_24 a discrete
Iwan of 24 sliders); ratio to real time, and the continuous Iwan's CPU over the sliders'. Light damping needs seconds of
simulated time per step-sine step, so this ratio is what a step-sine set costs.

Run: .venv/bin/python benchmarks/bench_structure_rig.py [--seconds 60] [--repeats 3] [--smoke]
Prints a human line per law (median of the repeats) and one JSON line.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.config import CONFIG_DIR, load_config  # noqa: E402
from labjoint.hardware.sim import open_sim  # noqa: E402


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args()
    if args.smoke:
        args.seconds = 0.5
    bench = Bench.from_args("structure_rig", args, repeats=3)
    cpu = {}
    # iwan: the continuous density (Masing's rules with memory); iwan_24: 24 equal sliders
    for law, joint in (("iwan", {}), ("iwan_24", {"elements": 24}), ("jenkins", {}),
                       ("richard_abbott", {}), ("linear", {})):
        joint = {"law": law.split("_24")[0], **joint}
        cfg = load_config(CONFIG_DIR / "rig-structure-sim.toml", {"sim": {"joint": joint}})
        gen, daq, rig = open_sim(cfg)
        gen.apply(28.0, 4.0)
        gen.set_output(True)
        daq.start()
        block = cfg.daq.block_samples
        bench.warm_up(lambda: daq.read(block), "one DAQ block per law")
        fs = daq.sample_rate_hz
        n_blocks = max(1, int(round(args.seconds * fs / block)))

        def run() -> None:
            for _ in range(n_blocks):
                daq.read(block)

        t = bench.repeat(run)
        simulated = n_blocks * block / fs
        print(f"{law}: {simulated:.1f} s of {len(daq.channels)} channels at {fs:.0f} S/s "
              f"({rig.substeps} steps/sample, {rig.model.omega.size} modes) in {t.median:.3f} s")
        bench.figure(f"structural rig, {law} joint", simulated / t.median, "real time",
                     value=t.median, unit="s", timing=t)
        cpu[law] = t.cpu_median
        daq.close()
        gen.close()
    bench.figure("continuous Iwan over 24 sliders, CPU", cpu["iwan"] / cpu["iwan_24"], "24 sliders' CPU")
    bench.finish(simulated_s=args.seconds)


if __name__ == "__main__":
    main()
