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
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from labjoint.structure import load_structure, modes  # noqa: E402
from labjoint.structure.epmc import epmc_backbone  # noqa: E402
from labjoint.structure.frf import system_of  # noqa: E402
from labjoint.structure.law import JointLaw  # noqa: E402
from labjoint.structure.system import JointElement  # noqa: E402

SEED000 = ROOT / "configs" / "structure-seed000.toml"
IWAN = {"linear_stiffness.k": 9.8e7, "iwan.K_T": 2.28e8, "iwan.F_S": 15000.0, "iwan.chi": 0.0, "iwan.beta": 0.0}


def main(argv: list[str]) -> int:
    smoke = "--smoke" in argv
    n = 8 if smoke else 50
    with open("/proc/loadavg") as fh:
        load = fh.read().split()[:3]
    s = load_structure(SEED000)
    modes(s, 2)                                                 # warm-up (imports, caches)
    t = time.perf_counter()
    modes(s, 2)
    t_modal = time.perf_counter() - t
    t = time.perf_counter()
    sysm = system_of(s, 10)
    t_reduce = time.perf_counter() - t
    law = JointLaw("linear_stiffness+iwan", IWAN)
    iwan = replace(sysm, elements=tuple(JointElement(replace(e.joint, law=law)) for e in sysm.elements))
    A = np.geomspace(1e-5, 5e-3, n)
    print(f"load {' '.join(load)}; one linear modal solve {t_modal * 1e3:.1f} ms; Craig-Bampton "
          f"reduction {t_reduce * 1e3:.0f} ms")
    for name, system in (("richard_abbott (file)", sysm), ("linear_stiffness+iwan", iwan)):
        epmc_backbone(system, A[:2], harmonics=3, samples=64, sensor="free_end")      # warm-up (numba)
        t = time.perf_counter()
        b = epmc_backbone(system, A, harmonics=3, samples=64, sensor="free_end")
        dt = time.perf_counter() - t
        f, z = b.array("frequency_hz"), b.array("damping_ratio")
        print(f"{name:24s} {n} points in {dt:.2f} s ({dt / n * 1e3:.0f} ms/point; {dt / t_modal:.2f}x a "
              f"modal solve, {dt / t_reduce:.2f}x the reduction); f {f[0]:.4f} -> {f[-1]:.4f} Hz, "
              f"zeta {z[0]:.4g} -> {z[-1]:.4g}; goal <= 2 s: {'met' if dt <= 2 else 'NOT met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
