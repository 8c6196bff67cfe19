"""Benchmark: one structure diagnosis (issue 32 item 6): seed 000's assembly with a linear
baseline joint, a step-sine FRF set of 29 steps x 3 levels (87 steps: 2, 8, 16.5 N, 1 %
noise, harmonics 1-3, three sensors) with a hidden Iwan + viscous joint, and 7 candidate
effects. Timed as wall and CPU time (target <= 10 s on a quiet 2-core machine; on a shared one the
process's CPU time is the better estimate of the quiet wall time) and as the ratio
against the same diagnosis with finite-difference Jacobians of the search (one whole
prediction per parameter) in the same process.

Run: ``python benchmarks/bench_structure_diagnose.py [--fd]`` (``cat /proc/loadavg`` beside it).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import labjoint.compare.kinds.frf_fit as frf_fit  # noqa: E402
from frfdata import hidden_law, linear_joint_structure_dict  # noqa: E402
from labjoint.compare.diagnosis import DiagnoseSettings, diagnose_prepared  # noqa: E402
from labjoint.compare.kinds.frf import prepare_frfsets  # noqa: E402
from labjoint.structure import structure_from_dict  # noqa: E402
from labjoint.structure.predict import FrfPredictor, synthetic_frfset  # noqa: E402

CANDIDATES = ("viscous", "iwan", "coulomb", "richard_abbott", "cubic_stiffness", "offset", "inertia")


def run(analytic: bool) -> tuple[float, float, str]:
    frf_fit.ANALYTIC_JACOBIAN = analytic
    pr = FrfPredictor(structure_from_dict(linear_joint_structure_dict()), modes=4, harmonics=3, samples=32)
    f0 = pr.natural_frequencies(1)[0]
    fs = synthetic_frfset(pr, hidden_law(), np.linspace(0.96 * f0, 1.02 * f0, 29), [2.0, 8.0, 16.5],
                          None, harmonics=3, noise=0.01, floor=1e-4, seed=1)
    pr = FrfPredictor(pr.structure, modes=4, harmonics=3, samples=32, system=pr.system)  # cold caches
    t, c = time.perf_counter(), time.process_time()
    ms = prepare_frfsets([("bench", fs)], pr)
    dg = diagnose_prepared(ms, "linear_stiffness", settings=DiagnoseSettings(candidates=CANDIDATES))
    return time.perf_counter() - t, time.process_time() - c, dg.verdict


def main(fd: bool, only_fd: bool = False) -> None:
    print(f"load {Path('/proc/loadavg').read_text().split()[:3]}")
    if only_fd:
        tf, cf, vf = run(False)
        print(f"finite differences: {tf:.1f} s wall, {cf:.1f} s CPU  ({vf})")
        return
    ta, ca, va = run(True)
    print(f"analytic Jacobians: {ta:.1f} s wall, {ca:.1f} s CPU  ({va})")
    if fd:
        tf, cf, vf = run(False)
        print(f"finite differences: {tf:.1f} s wall, {cf:.1f} s CPU  ({vf})  CPU ratio {cf / ca:.2f}x")
    print(f"load {Path('/proc/loadavg').read_text().split()[:3]}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fd", action="store_true", help="also time the finite-difference search")
    ap.add_argument("--only-fd", action="store_true", help="time only the finite-difference search")
    a = ap.parse_args()
    main(a.fd, a.only_fd)
