"""Benchmark: one structure diagnosis (issue 32 item 6): seed 000's assembly with a linear
baseline joint, a step-sine FRF set of 29 steps x 3 levels (87 steps: 2, 8, 16.5 N, 1 %
noise, harmonics 1-3, three sensors) with a hidden Iwan + viscous joint, and 7 candidate
effects. Timed as wall and CPU time (target <= 10 s on a quiet 2-core machine; on a shared one the
process's CPU time is the better estimate of the quiet wall time) and as the ratio
against the same diagnosis with finite-difference Jacobians of the search (one whole
prediction per parameter) in the same process.

Also the diagnosis against one harmonic-balance prediction of the same FRF set with the
hidden law (how many predictions' worth it costs), in the same process.

Run: ``python benchmarks/bench_structure_diagnose.py [--fd | --only-fd] [--smoke] [--repeats N]``
(smoke: 7 steps x 2 levels, 2 candidates, same code path; the load average is printed before
and after).
"""

from __future__ import annotations

import contextlib
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import labjoint.compare.kinds.frf_fit as frf_fit  # noqa: E402
from benchmarks.harness import Bench, parser  # noqa: E402
from frfdata import hidden_law, linear_joint_structure_dict  # noqa: E402
from labjoint.compare.diagnosis import DiagnoseSettings, diagnose_prepared  # noqa: E402
from labjoint.compare.kinds.frf import prepare_frfsets  # noqa: E402
from labjoint.structure import structure_from_dict  # noqa: E402
from labjoint.structure.predict import FrfPredictor, synthetic_frfset  # noqa: E402

CANDIDATES = ("viscous", "iwan", "coulomb", "richard_abbott", "cubic_stiffness", "offset", "inertia")


SMOKE_CANDIDATES = ("viscous", "iwan")
#: (steps, force levels N, candidates): the benchmark's and the smoke run's
SIZES = {False: (29, (2.0, 8.0, 16.5), CANDIDATES), True: (7, (2.0, 16.5), SMOKE_CANDIDATES)}


def case(smoke: bool):
    """The predictor (cold caches) and the synthetic FRF set of the hidden Iwan + viscous joint."""
    steps, levels, _ = SIZES[smoke]
    with contextlib.chdir(ROOT):             # tests/frfdata reads configs/ relative to the root
        d = linear_joint_structure_dict()
    pr = FrfPredictor(structure_from_dict(d), modes=4, harmonics=3, samples=32)
    f0 = pr.natural_frequencies(1)[0]
    fs = synthetic_frfset(pr, hidden_law(), np.linspace(0.96 * f0, 1.02 * f0, steps), list(levels),
                          None, harmonics=3, noise=0.01, floor=1e-4, seed=1)
    pr = FrfPredictor(pr.structure, modes=4, harmonics=3, samples=32, system=pr.system)  # cold caches
    return pr, fs


def run(analytic: bool, smoke: bool = False) -> tuple[float, float, str]:
    """One diagnosis (data made first, untimed): wall s, CPU s, verdict."""
    frf_fit.ANALYTIC_JACOBIAN = analytic
    pr, fs = case(smoke)
    t, c = time.perf_counter(), time.process_time()
    ms = prepare_frfsets([("bench", fs)], pr)
    dg = diagnose_prepared(ms, "linear_stiffness", settings=DiagnoseSettings(candidates=SIZES[smoke][2]))
    return time.perf_counter() - t, time.process_time() - c, dg.verdict


def main() -> int:
    ap = parser(__doc__)
    ap.add_argument("--fd", action="store_true", help="also time the finite-difference search")
    ap.add_argument("--only-fd", action="store_true", help="time only the finite-difference search")
    args = ap.parse_args()
    bench = Bench.from_args("structure_diagnose", args, repeats=1)
    n = args.repeats or 1                      # a diagnosis is long: one unless asked
    steps, levels, cands = SIZES[args.smoke]
    print(f"{steps} steps x {len(levels)} levels, {len(cands)} candidates", flush=True)
    pr, fs = case(args.smoke)
    law = hidden_law()
    bench.warm_up(lambda: pr.predict(fs, law, warm=False), "one FRF-set prediction, hidden law (numba)")
    ref = bench.repeat(lambda: pr.predict(fs, law, warm=False), repeats=3)
    print(f"one prediction of the FRF set (hidden law, harmonic balance): {ref.median:.3f} s")
    kinds = ([False] if args.only_fd else [True] + ([False] if args.fd else []))
    cpu = {}
    for analytic in kinds:
        tm = bench.repeat(lambda: run(analytic, args.smoke), repeats=n)
        wall = tm.median_of([r[0] for r in tm.results])
        cpu[analytic] = tm.median_of([r[1] for r in tm.results])
        label = "analytic Jacobians" if analytic else "finite differences"
        print(f"{label}: {wall:.1f} s wall, {cpu[analytic]:.1f} s CPU  ({tm.result[2]})"
              + (f"  CPU ratio {cpu[False] / cpu[True]:.2f}x" if not analytic and True in cpu else ""))
        bench.figure(f"diagnosis, {label} / target", wall / 10.0, "the 10 s target (quiet 2-core)",
                     value=wall, unit="s wall", target="<= 1", cpu_s=cpu[analytic],
                     verdict=tm.result[2])
        bench.figure(f"diagnosis CPU, {label} / target", cpu[analytic] / 10.0,
                     "the 10 s target (CPU time: the quiet wall time's estimate on a shared machine)",
                     value=cpu[analytic], unit="s CPU", target="<= 1")
        bench.figure(f"diagnosis, {label} / one FRF-set prediction", wall / ref.median,
                     "one harmonic-balance prediction of the same FRF set with the hidden law (median of 3)",
                     value=wall, unit="s")
    if len(cpu) == 2:
        bench.figure("diagnosis CPU, finite differences / analytic", cpu[False] / cpu[True],
                     "the same diagnosis with analytic Jacobians (CPU time)", value=cpu[False],
                     unit="s CPU")
    bench.finish()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
