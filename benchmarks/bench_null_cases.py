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

Run: ``python benchmarks/bench_null_cases.py [n_cases]`` (default 20 + 20; ~10 min on
2 cores). Prints one line per case and the rates, with time per diagnosis.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

from labrecords import EFFECTS, LabCase  # noqa: E402

from labjoint.compare import diagnose_report  # noqa: E402

BASELINE = "linear_stiffness+coulomb"


def run_case(case: LabCase, root: Path) -> tuple[bool, str, float]:
    """(correct, verdict, seconds) of one case."""
    paths = case.write(root / f"case{case.seed}_{case.effect or 'null'}")
    t0 = time.perf_counter()
    d = diagnose_report(paths, BASELINE)
    dt = time.perf_counter() - t0
    if case.effect is None:
        return d.adequate, d.verdict, dt
    best = d.best
    found = best is not None and case.effect in {best.effect, *best.tie_with}
    return (not d.adequate) and found, d.verdict, dt


def main(n: int = 20) -> int:
    effects = list(EFFECTS)
    cases = [LabCase.draw(100 + i) for i in range(n)]
    cases += [LabCase.draw(500 + i, effects[i % len(effects)]) for i in range(n)]
    fp = fn = 0
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for case in cases:
            ok, verdict, dt = run_case(case, Path(tmp))
            times.append(dt)
            kind = case.effect or "null"
            if not ok:
                fp += case.effect is None
                fn += case.effect is not None
            print(f"{kind:16s} seed {case.seed:4d} {'ok ' if ok else 'WRONG'} {dt:6.1f} s  {verdict[:110]}",
                  flush=True)
    print(f"false positives: {fp}/{n} null cases ({100 * fp / n:.0f} %); "
          f"false negatives: {fn}/{n} single-effect cases ({100 * fn / n:.0f} %)")
    print(f"time per diagnosis: median {sorted(times)[len(times) // 2]:.1f} s, max {max(times):.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1]) if len(sys.argv) > 1 else 20))
