"""Benchmark: false-positive and false-negative rates of ``diagnose`` on lab-like records.

Cases from ``tests/labrecords.py``: a Jenkins + parallel-spring joint (the baseline
``linear_stiffness+coulomb`` explains it exactly) with random stiffnesses, slip force,
two drive frequencies (150-300 Hz and 400-700 Hz) x three amplitudes, and every record
carrying rest before and after, raised-cosine ramps, a DC displacement offset, 50/60 Hz
mains hum on the force, white noise and 24-bit quantisation, written as CSV and read
through the import path.

- null cases (nothing hidden): a false positive is any verdict but adequate;
- single-effect cases (``viscous``, ``cubic_stiffness`` or ``inertia`` hidden, in turn):
  a false negative is a verdict of adequate, or a best significant candidate that is
  not the hidden effect (a stated tie that includes it counts as found).

Run: ``python benchmarks/bench_null_cases.py [--cases 20] [--smoke]`` (default 20 + 20;
~10 min on 2 cores; smoke: 1 + 1). Prints one line per case and the rates, with the time
per diagnosis as a multiple of the diagnosed records' duration (real time).
"""

from __future__ import annotations

import statistics
import sys
from dataclasses import replace
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
sys.path.insert(0, str(HERE.parent))

from labrecords import EFFECTS, LabCase  # noqa: E402

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.compare import diagnose_report  # noqa: E402
from labjoint.storage import read_any  # noqa: E402

BASELINE = "linear_stiffness+coulomb"


def run_case(case: LabCase, root: Path, **options) -> tuple[bool, str, float, float]:
    """(correct, verdict, seconds, the records' duration in s) of one case; ``options``
    go to diagnose (smoke: fewer candidates)."""
    paths = case.write(root / f"case{case.seed}_{case.effect or 'null'}")
    duration = 0.0
    for path in paths:
        run = read_any(path)
        duration += len(run.time) / run.sample_rate_hz
    t0 = time.perf_counter()
    d = diagnose_report(paths, BASELINE, **options)
    dt = time.perf_counter() - t0
    if case.effect is None:
        return d.adequate, d.verdict, dt, duration
    best = d.best
    found = best is not None and case.effect in {best.effect, *best.tie_with}
    return (not d.adequate) and found, d.verdict, dt, duration


def main() -> int:
    ap = parser(__doc__)
    ap.add_argument("--cases", type=int, default=20, help="null cases (and as many single-effect)")
    args = ap.parse_args()
    n = 1 if args.smoke else args.cases
    bench = Bench.from_args("null_cases", args, repeats=1)
    effects = list(EFFECTS)
    cases = [LabCase.draw(100 + i) for i in range(n)]
    cases += [LabCase.draw(500 + i, effects[i % len(effects)]) for i in range(n)]
    options = {}
    if args.smoke:       # shorter records (same artefacts), two candidates: the code path only
        cases = [replace(c, cycles=16, amplitudes=c.amplitudes[:2]) for c in cases]
        options = {"candidates": sorted({effects[0], "cubic_stiffness"})}
    fp = fn = 0
    times, per_real = [], []
    with tempfile.TemporaryDirectory() as tmp:
        bench.warm_up(lambda: run_case(replace(cases[0], seed=99), Path(tmp), **options),
                      "one null case, untimed")
        for case in cases:
            ok, verdict, dt, duration = run_case(case, Path(tmp), **options)
            times.append(dt)
            per_real.append(dt / duration)
            kind = case.effect or "null"
            if not ok:
                fp += case.effect is None
                fn += case.effect is not None
            print(f"{kind:16s} seed {case.seed:4d} {'ok ' if ok else 'WRONG'} {dt:6.1f} s  {verdict[:110]}",
                  flush=True)
    bench.figure("false positives", fp / n, f"the {n} null cases (fraction)", value=fp,
                 unit="cases", target="0")
    bench.figure("false negatives", fn / n, f"the {n} single-effect cases (fraction)", value=fn,
                 unit="cases", target="0")
    bench.figure("time per diagnosis", statistics.median(per_real),
                 "the diagnosed records' duration (real time; median over the cases)",
                 value=statistics.median(times), unit="s per case (median)")
    bench.finish(cases=2 * n, max_s=max(times))
    return 0


if __name__ == "__main__":
    sys.exit(main())
