"""Benchmark: stage-2 updating (seed 000 Eq. 9) on simulated FRF sets with known parameters
(issue 15; one run, this shared 2-core machine).

The seed 000 assembly with a hidden Richard-Abbott joint (ke = 1e10 N/m, kp = 1e8 N/m,
F_y = 3 kN, n = 2 per thread), FRF sets computed by Craig-Bampton + HBM at 7 steps
around mode 1 and 4 around mode 2, at 5 and 30 N, with 1 % complex noise per phasor
(stated as its response_std). kp, F_y and n are fitted from a start off by factors 3,
1/2 and 1.5 on the mode-1 steps and validated on the mode-2 steps; reported: each
parameter's recovered value, standard error and |error| / se (within the uncertainty:
<= 2 in ~95 % of repetitions), the fit's Eq. 9 RMS on the fit and the validation steps,
and the wall time. ``--seeds N`` repeats with N noise draws and counts the recoveries.

Figures: the fraction of estimates within 2 se (reference: the estimates made), and the fit's
median wall time against one evaluation of the FRF set's prediction (how many evaluations'
worth a fit costs; its ``n_evals`` says how many it made).
Run: ``python benchmarks/bench_structure_stage2.py [--seeds N] [--smoke]`` (smoke: 3 + 2
steps, 2 harmonic samples fewer, one seed).
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.structure import load_structure  # noqa: E402
from labjoint.structure.predict import FrfPredictor, synthetic_frfset  # noqa: E402
from labjoint.structure.stage2 import update_nonlinear  # noqa: E402

TRUTH = {"richard_abbott.ke": 1e10, "richard_abbott.kp": 1e8, "richard_abbott.F_y": 3e3,
         "richard_abbott.n": 2.0}
START = {"richard_abbott.kp": 3e8, "richard_abbott.F_y": 1.5e3, "richard_abbott.n": 3.0}


def main() -> None:
    from labjoint.structure.modal import with_parameter
    ap = parser(__doc__)
    ap.add_argument("--seeds", type=int, default=1)
    args = ap.parse_args()
    bench = Bench.from_args("structure_stage2", args, repeats=1)
    seeds, n1, n2 = (1, 3, 2) if args.smoke else (args.seeds, 7, 4)
    s0 = load_structure(ROOT / "configs" / "structure-seed000.toml")   # the steel layer's tie, as
    s0 = with_parameter(s0, "transverse_stiffness_n_per_m", 2.1323e12)  # when these figures were taken
    pr = FrfPredictor(s0, modes=10, harmonics=1, samples=32)
    truth = pr.law.with_params(**TRUTH)
    f1, f2 = pr.natural_frequencies(2)
    freqs = np.r_[np.linspace(0.85 * f1, 1.05 * f1, n1), np.linspace(0.97 * f2, 1.03 * f2, n2)]
    inside, total, walls, evals = 0, 0, [], []
    t_set = None
    for seed in range(seeds):
        fs = synthetic_frfset(pr, truth, freqs, [5.0, 30.0], ("free_end",), harmonics=1,
                              noise=0.01, seed=seed)
        if t_set is None:       # the reference: one prediction of the set (after a first)
            bench.warm_up(lambda: synthetic_frfset(pr, truth, freqs, [5.0, 30.0], ("free_end",),
                                                   harmonics=1, noise=0.0, seed=0),
                          "one FRF set prediction")
            t_set = bench.repeat(lambda: synthetic_frfset(
                pr, truth, freqs, [5.0, 30.0], ("free_end",), harmonics=1, noise=0.0, seed=0), 3)
        t0 = time.perf_counter()
        res = update_nonlinear(pr, fs, law=truth.with_params(**START))
        dt = time.perf_counter() - t0
        walls.append(dt)
        evals.append(res.fit.n_evals)
        print(f"seed {seed}: {res.fit_steps} fit steps (mode 1), {res.validation_steps} validation "
              f"steps (mode 2); {res.fit.n_evals} evaluations, {dt:.1f} s; Eq. 9 RMS fit "
              f"{100 * res.error_fit:.2f} %, validation {100 * res.error_validation:.2f} % "
              "(noise 1 %)")
        for k in START:
            v, se = res.fit.values[k], res.fit.stderr[k]
            z = abs(v - TRUTH[k]) / se
            inside += z <= 2
            total += 1
            print(f"  {k:20s} {v:.5g} +- {se:.2g} (truth {TRUTH[k]:.5g}, start {START[k]:.3g}): "
                  f"|error| = {z:.2f} se")
        print(f"  as seed 000's layer: {', '.join(f'{k} {v:.4g}' for k, v in res.layer.items())}")
    print(f"recovered within 2 se: {inside} of {total} parameter estimates")
    bench.figure("estimates within 2 standard errors", inside / total,
                 f"the {total} estimates made (fraction; ~0.95 expected)", value=inside,
                 unit="estimates")
    bench.figure("stage-2 fit / one FRF-set prediction", statistics.median(walls) / t_set.median,
                 "one prediction of the same FRF set (median of 3)",
                 value=statistics.median(walls), unit="s per fit (median over seeds)",
                 evaluations=evals)
    bench.finish(seeds=seeds)


if __name__ == "__main__":
    main()
