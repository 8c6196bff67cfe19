"""Benchmark: one structure diagnosis (issue 32 item 6): seed 000's assembly with a linear
baseline joint, a step-sine FRF set of 29 steps x 3 levels (87 steps: 2, 8, 16.5 N, 1 %
noise, harmonics 1-3, three sensors) with a hidden Iwan + viscous joint, and 7 candidate
effects. Timed as wall and CPU time (target <= 10 s on a quiet 2-core machine; on a shared one the
process's CPU time is the better estimate of the quiet wall time).

Compared in the same process (``--python``): the same diagnosis through the Python path
(``labjoint.structure.law.KERNEL = False``: laws evaluated per history, finite-difference
element Jacobians, the harmonic balance's Newton in Python; ``predict.SLOPE_START = False``:
each step re-solved from the last solution), the code before issue 32 item 6's speed-up
apart from small array-handling changes; the two alternate, and the verdict and every
candidate's validation NRMSE are printed for both. ``--fd``: the search with
finite-difference Jacobians (one whole prediction per parameter).

Also the diagnosis against one harmonic-balance prediction of the same FRF set with the
hidden law (how many predictions' worth it costs), in the same process.

Run: ``python benchmarks/bench_structure_diagnose.py [--python] [--fd] [--smoke] [--repeats N]``
(smoke: 7 steps x 2 levels, 2 candidates, same code path; the load average is printed before
and after).
"""

from __future__ import annotations

import contextlib
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import labjoint.compare.kinds.frf_fit as frf_fit  # noqa: E402
import labjoint.structure.law as law_module  # noqa: E402
import labjoint.structure.predict as predict_module  # noqa: E402
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


#: the variants timed: (label, analytic search Jacobian, compiled kernels and slope starts)
VARIANTS = {"compiled": ("compiled kernels", True, True), "python": ("Python path", True, False),
            "fd": ("finite-difference search", False, True)}


def run(variant: str, smoke: bool = False) -> tuple[float, float, str, dict[str, float]]:
    """One diagnosis (data made first, untimed): wall s, CPU s, verdict, candidates'
    validation NRMSE."""
    _, analytic, fast = VARIANTS[variant]
    frf_fit.ANALYTIC_JACOBIAN = analytic
    law_module.KERNEL = predict_module.SLOPE_START = fast
    try:
        pr, fs = case(smoke)
        t, c = time.perf_counter(), time.process_time()
        ms = prepare_frfsets([("bench", fs)], pr)
        dg = diagnose_prepared(ms, "linear_stiffness", settings=DiagnoseSettings(candidates=SIZES[smoke][2]))
        wall, cpu = time.perf_counter() - t, time.process_time() - c
    finally:
        frf_fit.ANALYTIC_JACOBIAN = True
        law_module.KERNEL = predict_module.SLOPE_START = True
    return wall, cpu, dg.verdict, {cd.effect: round(cd.nrmse_after_validation, 6) for cd in dg.candidates}


def main() -> int:
    ap = parser(__doc__)
    ap.add_argument("--python", action="store_true", help="also time the Python path (the reference)")
    ap.add_argument("--fd", action="store_true", help="also time the finite-difference search")
    args = ap.parse_args()
    bench = Bench.from_args("structure_diagnose", args, repeats=1)
    n = args.repeats or 1                      # a diagnosis is long: one unless asked
    steps, levels, cands = SIZES[args.smoke]
    print(f"{steps} steps x {len(levels)} levels, {len(cands)} candidates", flush=True)
    pr, fs = case(args.smoke)
    law = hidden_law()
    bench.warm_up(lambda: (pr.predict(fs, law, warm=False), run("compiled", True)),
                  "one FRF-set prediction, hidden law, and a smoke diagnosis (numba)")
    ref = bench.repeat(lambda: pr.predict(fs, law, warm=False), repeats=3)
    print(f"one prediction of the FRF set (hidden law, harmonic balance): {ref.median:.3f} s")
    kinds = ["compiled"] + (["python"] if args.python else []) + (["fd"] if args.fd else [])
    res: dict[str, list] = {k: [] for k in kinds}
    for _ in range(n):                         # the variants alternate: both see the same load
        for k in kinds:
            res[k].append(run(k, args.smoke))
    med = {k: (statistics.median(r[0] for r in v), statistics.median(r[1] for r in v)) for k, v in res.items()}
    for k in kinds:
        wall, cpu = med[k]
        label = VARIANTS[k][0]
        verdict, nrmse = res[k][-1][2], res[k][-1][3]
        print(f"{label}: {wall:.1f} s wall, {cpu:.1f} s CPU  ({verdict})\n  candidates' validation NRMSE: "
              + ", ".join(f"{e} {100 * v:.4g} %" for e, v in nrmse.items()), flush=True)
        if k == "compiled":
            bench.figure("diagnosis wall / target", wall / 10.0, "the 10 s target (quiet 2-core)",
                         value=wall, unit="s wall", target="<= 1", cpu_s=cpu, verdict=verdict,
                         candidates_validation_nrmse=nrmse)
            bench.figure("diagnosis CPU / target", cpu / 10.0,
                         "the 10 s target (CPU time: the quiet wall time's estimate on a shared machine)",
                         value=cpu, unit="s CPU", target="<= 1")
            bench.figure("diagnosis / one FRF-set prediction", wall / ref.median,
                         "one harmonic-balance prediction of the same FRF set with the hidden law "
                         "(median of 3)", value=wall, unit="s")
        else:
            base = res["compiled"][-1][3]
            same = verdict == res["compiled"][-1][2] and base.keys() == nrmse.keys() and all(
                abs(nrmse[e] - base[e]) <= 1e-4 * max(abs(base[e]), 1e-9) for e in base)
            bench.figure(f"diagnosis CPU, {label} / compiled", cpu / med["compiled"][1],
                         f"the same diagnosis through the compiled kernels (CPU time, alternating, "
                         f"median of {n})", value=cpu, unit="s CPU", verdict=verdict,
                         candidates_validation_nrmse=nrmse, same_answer=same)
    bench.finish()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
