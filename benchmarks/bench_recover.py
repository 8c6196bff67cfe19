"""`labjoint recover` over a directory of copies of one run (issue 33 item 18).

A lab copies a run file around (a backup folder synced back, a script's loop): 1,000
files holding the same run. Before, every recover "added" each copy again (each replaced
the last in the catalog) at a full read and a commit per file (80 s per recover). Now a
copy is recognised from the run's name and uid alone and listed, once, per run.

Printed (ratios, so the machine's load cancels): the time of the second recover per
copy, against reading one run file whole (``open_run`` + its catalog record) per copy.
Target: the repeated recover costs less than 0.3 of a full read per copy. Both are the
median of repeats (the repeated recover and the reads alternate, so both see the same
load); the first sync is timed once (it is first only once).
``--smoke``: 20 copies, the same code path.

Usage: ``.venv/bin/python benchmarks/bench_recover.py [--copies 1000] [--repeats N] [--smoke]``.
"""

from __future__ import annotations

import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.documents import Block, RunStart, RunStop  # noqa: E402
from labjoint.hardware.interfaces import ChannelSpec  # noqa: E402
from labjoint.storage import Catalog, open_run  # noqa: E402
from labjoint.storage.run_record import record_from_run  # noqa: E402
from labjoint.storage.writer import RunWriter  # noqa: E402

TARGET = 0.3


def _one_run(d: Path) -> Path:
    chans = [ChannelSpec(n, "voltage", "voltage", "V", 1.0) for n in ("a", "b", "c", "d")]
    w = RunWriter(d)
    w("start", RunStart("uid-orig", "orig", chans, 50_000.0, {"frequency_hz": 400.0}))
    w("block", Block("uid-orig", 0, np.zeros((4, 50_000))))
    w("stop", RunStop("uid-orig", "complete", n_samples=50_000))
    return d / "orig.h5"


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--copies", type=int, default=1000)
    args = ap.parse_args()
    bench = Bench.from_args("recover", args, repeats=3)
    n = 20 if args.smoke else args.copies
    n_read = min(n, 200)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        src = _one_run(d)
        for k in range(n):
            shutil.copy(src, d / f"copy_{k:05d}.h5")

        def full_read() -> float:
            t0 = time.perf_counter()
            for k in range(n_read):
                with open_run(d / f"copy_{k:05d}.h5") as rf:
                    record_from_run(rf)
            return (time.perf_counter() - t0) / n_read

        bench.warm_up(lambda: full_read(), f"a full read of {n_read} copies")
        cat = Catalog(d / "catalog.sqlite")
        t0 = time.perf_counter()
        out = cat.sync(d)
        first = time.perf_counter() - t0
        reads, syncs = [], []
        for _ in range(bench.repeats):      # alternate: both see the same load
            reads.append(bench.repeat(full_read, 1))
            syncs.append(bench.repeat(lambda: cat.sync(d), 1))
        full = statistics.median(t.result for t in reads)
        second = statistics.median(t.median for t in syncs)
        out = syncs[-1].result
        copies = sum(len(v) for v in out["copies"].values())
        print(f"{n} copies: first sync {first:.2f} s, second {second:.2f} s (median of "
              f"{bench.repeats}) ({len(out['added'])} added, {copies} listed as copies)")
        ratio = second / n / full
        print(f"second sync per copy / full read per file = {ratio:.3f} (target < {TARGET:g}: "
              f"{'met' if ratio < TARGET else 'NOT met'})")
        bench.figure("second sync per copy / full read per file", ratio,
                     "reading one run file whole (open_run + its catalog record) per copy, "
                     "alternating with it", value=second / n * 1e3, unit="ms per copy",
                     target=f"< {TARGET:g}")
    bench.finish(copies=n, first_sync_s=first, full_read_s=full)


if __name__ == "__main__":
    main()
