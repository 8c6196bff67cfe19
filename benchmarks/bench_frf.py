"""FRF and modes of a long broadband record: speed as a multiple of real time, memory bounded.

A 10-minute, 4-channel (a force drive and three accelerometers), 51.2 kS/s record of a
structure with modes at 20, 55 and 180 Hz under random force is written as a labjoint
run file (HDF5, float64, 983 MB), block by block. Then, in a fresh subprocess each time,
the command-line entry (``labjoint.cli.main.main``) runs exactly what a user types,
``labjoint frf RUN --out FRF.json`` and ``labjoint modes FRF.json --band 5:300``, timed
after the process's imports (the run file read in blocks of 2^20 samples, Welch sums
accumulated block by block, 2^16-sample Hann segments end to end as
:func:`labjoint.signal.broadband.segment_length` chooses for a record that long; H1,
coherence, errors; automatic LSCF/LSFD). Printed: record length / wall time of the two
commands ("x real time"; Python's start-up and the imports, about 2 s of CPU, are not
counted), median over repeats with best and worst, their CPU time, the peak RSS of the
process and its RSS after the imports, and the load average before and after. The numerical core alone (the sums
fed from blocks already in memory, single precision) is timed in-process beside it.

Usage: ``python benchmarks/bench_frf.py [--minutes 10] [--repeats 3] [--smoke]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import signal as sps

FS = 51_200.0
BLOCK = 1 << 20
MODES_HZ = ((20.0, 0.02), (55.0, 0.015), (180.0, 0.01))
MIX = np.array([[1.0, 0.6, 0.3], [0.8, -0.5, 0.4], [0.5, -0.9, -0.6]])


def blocks(seconds: float, seed: int = 0):
    """(4, m) blocks of the record: force, three accelerations (filters carried across)."""
    rng = np.random.default_rng(seed)
    filt = []
    for fn, z in MODES_HZ:
        w = 2 * np.pi * fn
        b, a = sps.bilinear([1.0, 0.0, 0.0], [1.0, 2 * z * w, w * w], FS)
        filt.append((b, a, np.zeros(2)))
    n = int(seconds * FS)
    for start in range(0, n, BLOCK):
        f = rng.normal(size=min(BLOCK, n - start))
        modal = []
        for i, (b, a, zi) in enumerate(filt):
            y, zf = sps.lfilter(b, a, f, zi=zi)
            filt[i] = (b, a, zf)
            modal.append(y)
        acc = MIX @ np.array(modal) + 1e-3 * rng.normal(size=(3, f.size))
        yield np.vstack([f, acc])


def write_run(path: Path, seconds: float) -> None:
    import h5py

    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage import layout

    specs = [ChannelSpec(name="force", sensor="force", quantity="force", unit="N", sensitivity=1.0,
                         range_v=math.inf, coupling="DC")]
    specs += [ChannelSpec(name=f"acc{i}", sensor="accelerometer", quantity="acceleration",
                          unit="m/s^2", sensitivity=1.0, range_v=math.inf, coupling="DC")
              for i in (1, 2, 3)]
    with h5py.File(path, "w", libver="latest") as f:
        layout.create_layout(f, name=path.stem, uid="bench-" + path.stem, channels=specs,
                             sample_rate_hz=FS, metadata={"plan": "import"}, source="imported",
                             signal=None, data_units=None)
        data = f["entry/data"]
        n = 0
        for blk in blocks(seconds):
            m = blk.shape[1]
            for key, row in [("time", (n + np.arange(m)) / FS)] + list(zip([s.name for s in specs], blk)):
                data[key].resize((n + m,))
                data[key][n:n + m] = row
            n += m
        f["entry"]["n_samples"][()] = n
        f["entry"]["status"][()] = np.bytes_(b"complete")


CHILD = """
import json, resource, sys, time
from labjoint.cli.main import build_parser, main
build_parser()                                   # every command module imported
import sdypy.EMA, labjoint.identify.modes, labjoint.signal.broadband_stream  # noqa: E401
rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
out = []
for args in json.loads(sys.argv[1]):
    t0, c0 = time.perf_counter(), time.process_time()
    rc = main(args)
    out.append([time.perf_counter() - t0, time.process_time() - c0, rc])
print(json.dumps({"steps": out, "rss0": rss0,
                  "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}), file=sys.stderr)
"""


def pipeline(run: Path, frf: str) -> tuple[float, float, int, int, list[float]]:
    """`labjoint frf RUN --out FRF.json` then `labjoint modes FRF.json` in a fresh process,
    timed after its imports: (wall s, CPU s, peak RSS kB, RSS after imports kB, modes)."""
    steps = [["frf", str(run), "--out", frf, "--json", "--quiet"],
             ["modes", frf, "--band", "5:300", "--json"]]
    p = subprocess.run([sys.executable, "-c", CHILD, json.dumps(steps)], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1])))
    try:
        rep = json.loads(p.stderr.strip().splitlines()[-1])
    except (ValueError, IndexError):
        raise SystemExit(f"the pipeline failed: {p.stderr.strip()}") from None
    if any(rc for _, _, rc in rep["steps"]):
        raise SystemExit(f"the pipeline failed: {p.stderr.strip()}")
    modes = json.loads(p.stdout.strip().splitlines()[-1])["levels"][0]["modes"]
    wall = sum(w for w, _, _ in rep["steps"])
    cpu = sum(c for _, c, _ in rep["steps"])
    return wall, cpu, rep["rss"], rep["rss0"], [round(m["frequency_hz"], 3) for m in modes]


def core(seconds: float) -> float:
    """Wall time of the numerical core alone (the sums fed from blocks in memory, then the
    modes), in this process."""
    from labjoint.identify.modes import find_modes
    from labjoint.signal.broadband import segment_length
    from labjoint.signal.spectra import Welch

    pool = [b.astype(np.float32) for b, _ in zip(blocks(4 * BLOCK / FS, seed=1), range(4))]
    n = int(seconds * FS)
    L, ov = segment_length(n, FS)
    t0 = time.perf_counter()
    w = Welch(L, FS, 3, overlap=ov, dtype=np.float32)
    done = i = 0
    while done < n:
        b = pool[i % len(pool)]
        k = min(BLOCK, n - done)
        w.feed(b[0, :k], b[1:, :k])
        done, i = done + k, i + 1
    find_modes(w.freq_hz, w.estimates()["H1"], "acceleration", ["a", "b", "c"], (5.0, 300.0))
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--smoke", action="store_true", help="a 20 s record, one repeat (CI)")
    a = ap.parse_args()
    seconds = 20.0 if a.smoke else a.minutes * 60
    repeats = 1 if a.smoke else a.repeats
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as d:
        run = Path(d) / "long_random.h5"
        t0 = time.perf_counter()
        write_run(run, seconds)
        written = time.perf_counter() - t0
        frf = str(Path(d) / "frf.json")
        walls, cpus, rss, rss0, modes = [], [], 0, 0, []
        for _ in range(repeats):
            w, c, r, r0, modes = pipeline(run, frf)
            walls.append(w)
            cpus.append(c)
            rss, rss0 = max(rss, r), max(rss0, r0)
        size = run.stat().st_size
    ratios = sorted(seconds / t for t in walls)
    core_s = core(seconds)
    print(f"record: {seconds:g} s, 4 channels at {FS:g} S/s ({seconds * FS * 4 / 1e6:.1f} M samples), "
          f"run file {size / 2**20:.0f} MB (written in {written:.1f} s)")
    print(f"modes found (Hz): {modes}  (simulated {[m for m, _ in MODES_HZ]})")
    print(f"`labjoint frf` + `labjoint modes` from the run file: {statistics.median(ratios):.0f}x real "
          f"time (median of {repeats}; best {ratios[-1]:.0f}x, worst {ratios[0]:.0f}x), "
          f"{seconds / statistics.median(cpus):.0f}x on their CPU time")
    print(f"peak RSS of the process: {rss / 1024:.0f} MB, {rss0 / 1024:.0f} MB of it after the imports "
          f"(the record: {size / 2**20:.0f} MB)")
    print(f"numerical core alone (blocks in memory, float32): {seconds / core_s:.0f}x real time")
    print(f"load average before {load0[0]:.2f}, after {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
