"""Benchmark: backbones by the extended periodic motion concept on seed 000's assembly.

50 amplitude points (1e-5 .. 5e-3 m at the free end) of mode 1's EPMC backbone on the
Craig-Bampton reduced seed-000 assembly (10 kept modes, 3 harmonics, 64 AFT samples),
with (a) the structure file's own Richard-Abbott threads and (b) an Iwan micro-slip
law at the threads (linear_stiffness+iwan, the simulated rig's hidden law mapped onto
the layer: sticking stiffness 2 k_theta / r^2, 30 % of it elastic, F_S 15 kN, chi 0).
Reported: wall time, time per point, and ratios to one linear modal solve
(:func:`labjoint.structure.modes`, 2 modes) and to the reduction itself, all in this
process (the machine is shared: ratios, not seconds, are the figures), and the load.
Goal (issue 30): <= 2 s for the 50 points.

Run: ``python benchmarks/bench_backbone.py [--smoke]`` (smoke: 8 points).
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.structure import load_structure, modes  # noqa: E402
from labjoint.structure.epmc import epmc_backbone  # noqa: E402
from labjoint.structure.frf import system_of  # noqa: E402
from labjoint.structure.law import JointLaw  # noqa: E402
from labjoint.structure.system import JointElement  # noqa: E402

SEED000 = ROOT / "configs" / "structure-seed000.toml"
IWAN = {"linear_stiffness.k": 9.8e7, "iwan.K_T": 2.28e8, "iwan.F_S": 15000.0, "iwan.chi": 0.0, "iwan.beta": 0.0}


def main() -> int:
    args = parser(__doc__).parse_args()
    bench = Bench.from_args("backbone", args, repeats=1)
    n = 8 if args.smoke else 50
    s = load_structure(SEED000)
    bench.warm_up(lambda: modes(s, 2), "one modal solve: imports, caches")
    t_modal = bench.repeat(lambda: modes(s, 2), repeats=3).median
    t_reduce = bench.repeat(lambda: system_of(s, 10), repeats=1)
    sysm, t_reduce = t_reduce.result, t_reduce.median
    law = JointLaw("linear_stiffness+iwan", IWAN)
    iwan = replace(sysm, elements=tuple(JointElement(replace(e.joint, law=law)) for e in sysm.elements))
    A = np.geomspace(1e-5, 5e-3, n)
    print(f"one linear modal solve {t_modal * 1e3:.1f} ms; Craig-Bampton reduction "
          f"{t_reduce * 1e3:.0f} ms")
    for name, system in (("richard_abbott (file)", sysm), ("linear_stiffness+iwan", iwan)):
        bench.warm_up(lambda: epmc_backbone(system, A[:2], harmonics=3, samples=64, sensor="free_end"),
                      "two EPMC points (numba)")
        tm = bench.repeat(lambda: epmc_backbone(system, A, harmonics=3, samples=64, sensor="free_end"))
        b, dt = tm.result, tm.median
        f, z = b.array("frequency_hz"), b.array("damping_ratio")
        print(f"{name:24s} {n} points in {dt:.2f} s; f {f[0]:.4f} -> {f[-1]:.4f} Hz, "
              f"zeta {z[0]:.4g} -> {z[-1]:.4g}")
        bench.figure(f"EPMC backbone, {name}, {n} points / one linear modal solve", dt / t_modal,
                     "one linear modal solve (2 modes) of the same assembly", value=dt, unit="s",
                     target="<= 2 s for 50 points", timing=tm, per_reduction=dt / t_reduce)
    bench.finish()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
