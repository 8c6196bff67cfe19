"""`labjoint recover` over a directory of copies of one run (issue 33 item 18).

A lab copies a run file around (a backup folder synced back, a script's loop): 1,000
files holding the same run. Before, every recover "added" each copy again (each replaced
the last in the catalog) at a full read and a commit per file (80 s per recover). Now a
copy is recognised from the run's name and uid alone and listed, once, per run.

Printed (ratios, so the machine's load cancels): the time of the second recover per
copy, against reading one run file whole (``open_run`` + its catalog record) per copy.
Target: the repeated recover costs less than 0.3 of a full read per copy.

Usage: ``.venv/bin/python benchmarks/bench_recover.py [--copies 1000]``.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from labjoint.documents import Block, RunStart, RunStop
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage import Catalog, open_run
from labjoint.storage.run_record import record_from_run
from labjoint.storage.writer import RunWriter


def _one_run(d: Path) -> Path:
    chans = [ChannelSpec(n, "voltage", "voltage", "V", 1.0) for n in ("a", "b", "c", "d")]
    w = RunWriter(d)
    w("start", RunStart("uid-orig", "orig", chans, 50_000.0, {"frequency_hz": 400.0}))
    w("block", Block("uid-orig", 0, np.zeros((4, 50_000))))
    w("stop", RunStop("uid-orig", "complete", n_samples=50_000))
    return d / "orig.h5"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=1000)
    n = ap.parse_args().copies
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        src = _one_run(d)
        for k in range(n):
            shutil.copy(src, d / f"copy_{k:05d}.h5")
        t0 = time.perf_counter()
        for k in range(min(n, 200)):
            with open_run(d / f"copy_{k:05d}.h5") as rf:
                record_from_run(rf)
        full = (time.perf_counter() - t0) / min(n, 200)
        cat = Catalog(d / "catalog.sqlite")
        times = []
        for _ in range(2):
            t0 = time.perf_counter()
            out = cat.sync(d)
            times.append(time.perf_counter() - t0)
        copies = sum(len(v) for v in out["copies"].values())
        print(f"{n} copies: first sync {times[0]:.2f} s, second {times[1]:.2f} s "
              f"({len(out['added'])} added, {copies} listed as copies)")
        ratio = times[1] / n / full
        print(f"second sync per copy / full read per file = {ratio:.3f} (target < 0.3: "
              f"{'met' if ratio < 0.3 else 'NOT met'})")


if __name__ == "__main__":
    main()
