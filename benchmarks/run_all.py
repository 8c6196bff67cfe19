"""Run every benchmark in this folder, one subprocess each, and print their figures.

Usage: ``make bench`` (full sizes), ``make bench-smoke`` (``--smoke``: every benchmark at
tiny sizes, what tests/test_benchmarks_smoke.py runs in CI), or
``.venv/bin/python -m benchmarks.run_all [--smoke] [--json FILE] [name ...]``.
Each benchmark ends with one JSON line (benchmarks/harness.py); this collects them, prints
one line per figure (ratio, reference, load average before/after) and, with ``--json``,
writes them all to FILE.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="run only benchmarks whose name contains one")
    ap.add_argument("--smoke", action="store_true", help="tiny sizes (seconds each)")
    ap.add_argument("--json", type=Path, help="write every benchmark's JSON line here")
    args = ap.parse_args(argv)
    scripts = sorted(HERE.glob("bench_*.py"))
    if args.names:
        scripts = [s for s in scripts if any(a in s.stem for a in args.names)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(HERE.parent), *filter(None, [os.environ.get("PYTHONPATH")])])}
    failed, results = [], []
    for script in scripts:
        print(f"== {script.stem}", flush=True)
        proc = subprocess.run([sys.executable, str(script), *(["--smoke"] if args.smoke else [])],
                              cwd=HERE.parent, env=env, stdout=subprocess.PIPE, text=True)
        print(proc.stdout, end="", flush=True)
        try:
            out = json.loads(proc.stdout.strip().splitlines()[-1])
        except (IndexError, ValueError):
            out = None
        if proc.returncode != 0 or out is None:
            failed.append(script.stem)
            continue
        results.append(out)
    print("\n== summary (ratio, reference; load average 1 min before -> after)")
    for out in results:
        load = f"{out['load_before'][0]:.1f} -> {out['load_after'][0]:.1f}"
        for fig in out["figures"]:
            print(f"{out['benchmark']:17s} {fig['name'][:58]:58s} {fig['ratio']:10.4g}x "
                  f"{fig['reference'][:50]}  [load {load}]")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    if failed:
        print(f"FAILED: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
