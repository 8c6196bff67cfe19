"""Simulated rig speed: 10 s at 50 kS/s, 4 channels, read in DAQ blocks; ratio to real time.

Run: .venv/bin/python benchmarks/bench_sim.py [--seconds 10] [--block 5000] [--smoke]
Prints human lines and one JSON line (benchmarks/harness.py). Target >= 10x real time.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.config import load_config  # noqa: E402
from labjoint.hardware.sim import open_sim  # noqa: E402


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--block", type=int, default=5000)
    args = ap.parse_args()
    if args.smoke:
        args.seconds = 0.2
    bench = Bench.from_args("sim_rig", args, repeats=3)

    gen, daq, rig = open_sim(load_config())
    gen.apply(400.0, 20.0)
    gen.set_output(True)
    daq.start()
    bench.warm_up(lambda: daq.read(args.block), "one DAQ block")

    fs = daq.sample_rate_hz
    n_blocks = max(1, int(round(args.seconds * fs / args.block)))

    def run() -> None:
        for _ in range(n_blocks):
            daq.read(args.block)

    timing = bench.repeat(run)
    simulated = n_blocks * args.block / fs
    print(f"simulated {simulated:.1f} s of {len(daq.channels)} channels at {fs:.0f} S/s "
          f"({rig.substeps} steps/sample, {len(rig.rings.r_in)} rings): median "
          f"{timing.median:.3f} s, best {timing.best:.3f} s")
    bench.figure("simulated rig", simulated / timing.median, "real time", value=timing.median,
                 unit="s", target=">= 10", timing=timing)
    daq.close()
    gen.close()
    bench.finish(simulated_s=simulated, channels=len(daq.channels), sample_rate_hz=fs,
                 substeps=rig.substeps)


if __name__ == "__main__":
    main()
