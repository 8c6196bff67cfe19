"""`labjoint analyze` (loop pipeline) at 50 kS/s, 500 kS/s and 2 MS/s: peak memory and time.

For each rate a 10 s, 4-channel record (the joint of ``bench_analyze``: Iwan micro-slip,
viscous part, wear drift, noise, offsets; 400 Hz) is written as a labjoint run file, then
a fresh subprocess runs :func:`labjoint.identify.analyze.analyze_file` on it (the code
path of ``labjoint analyze``: calibrated channels read in blocks, zero-phase 3 kHz
low-pass, cycles, loop metrics) and reports its peak RSS (ru_maxrss) and wall time.

Goals (issue 12): peak RSS <= 1 GB at every rate (the filter's settling length used to
grow without bound at >= 1.25 MS/s), time growing linearly with the number of samples
(the "ns per sample" column stays flat), and the loop pipeline at >= 500x real time at
50 kS/s (``bench_analyze`` measures that on a longer record).

Figures: the worst peak RSS against 1 GB, and the ns per sample at the highest rate against
the lowest's (1 = linear), from the median of the repeats' wall times.

Usage: ``.venv/bin/python benchmarks/bench_rates.py [--seconds 10] [--rates 50e3,500e3,2e6]
[--repeats 3] [--smoke]``.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from benchmarks.harness import Bench, parser  # noqa: E402


def child_write(directory: str, seconds: float, fs: float) -> dict:
    sys.path.insert(0, str(HERE))
    from bench_analyze import write_run

    t0 = time.perf_counter()
    path, how = write_run(Path(directory), f"rate_{int(fs)}", seconds, fs)
    return {"path": str(path), "how": how, "write_s": time.perf_counter() - t0}


def child_analyze(path: str, repeats: int = 1) -> dict:
    import numpy as np

    from labjoint.identify.analyze import analyze_arrays, analyze_file

    t = np.arange(20_000) / 50_000.0                      # compile / load numba caches
    analyze_arrays(1e-6 * np.sin(2 * np.pi * 400 * t), np.cos(2 * np.pi * 400 * t), 50_000.0, 400.0)
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    walls, cpus = [], []
    for _ in range(repeats):
        cpu0, t0 = time.process_time(), time.perf_counter()
        res = analyze_file(path)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - cpu0)
    wall, cpu = sorted(walls)[len(walls) // 2], sorted(cpus)[len(cpus) // 2]
    return {"wall_s": wall, "cpu_s": cpu, "after_imports_mb": base,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "n_samples": res.metadata["n_samples"], "n_cycles": res.n_cycles,
            "w_mj": res.summary["energy_loss_j"] * 1e3,
            "c": res.summary["damping_ns_per_m"], "k": res.summary["stiffness_n_per_m"]}


def _child(*args: str) -> dict:
    proc = subprocess.run([sys.executable, __file__, "--child", *args], capture_output=True,
                          text=True)
    if proc.returncode != 0:
        raise SystemExit(f"subprocess {args[0]} failed:\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv: list[str]) -> int:
    ap = parser(__doc__)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--rates", default="50e3,500e3,2e6")
    ap.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        kind, *rest = args.child
        out = (child_write(rest[0], float(rest[1]), float(rest[2])) if kind == "write"
               else child_analyze(rest[0], int(rest[1])))
        print(json.dumps(out))
        return 0
    if args.smoke:
        args.seconds, args.rates = 0.5, "50e3,200e3"
    bench = Bench.from_args("rates", args, repeats=3)
    bench.numba = "compilation excluded: warm-up call (analyze_arrays, 20,000 samples) in each child"
    rates = [float(r) for r in args.rates.split(",")]
    per_sample = []
    print(f"{'rate S/s':>10} {'samples':>10} {'file MB':>8} {'peak RSS MB':>11} "
          f"{'wall s':>7} {'x real':>7} {'ns/sample':>9} {'W mJ':>7} {'C Ns/m':>7} {'K MN/m':>7}")
    worst = 0.0
    for fs in rates:
        with tempfile.TemporaryDirectory(prefix="bench_rates_") as tmp:
            w = _child("write", tmp, str(args.seconds), str(fs))
            size = Path(w["path"]).stat().st_size / 1e6
            r = _child("analyze", w["path"], str(bench.repeats))
        worst = max(worst, r["peak_mb"])
        per_sample.append(r["wall_s"] / r["n_samples"])
        print(f"{fs:>10.3g} {r['n_samples']:>10d} {size:>8.0f} {r['peak_mb']:>11.0f} "
              f"{r['wall_s']:>7.2f} {args.seconds / r['wall_s']:>7.0f} "
              f"{1e9 * r['wall_s'] / r['n_samples']:>9.1f} {r['w_mj']:>7.4f} {r['c']:>7.0f} "
              f"{r['k'] / 1e6:>7.2f}", flush=True)
    bench.figure("worst peak RSS / 1 GB", worst / 1024, "the 1 GB memory goal", value=worst,
                 unit="MB", target="<= 1")
    bench.figure(f"ns per sample at {rates[-1]:g} S/s / at {rates[0]:g} S/s",
                 per_sample[-1] / per_sample[0], f"the lowest rate's ns per sample (1 = linear; "
                 f"median of {bench.repeats})", value=1e9 * per_sample[-1], unit="ns/sample")
    bench.finish(seconds=args.seconds, rates=rates)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
