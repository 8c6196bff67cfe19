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
Figures (benchmarks/README.md): the two commands as a multiple of real time (wall, and per
CPU second), the peak RSS as a fraction of the record's size, the core alone as a multiple
of real time; each a median of repeats after an untimed warm-up (a pipeline run, which also
writes numba's cache, and a short core call). ``--smoke``: a 20 s record, same code path.

Usage: ``python benchmarks/bench_frf.py [--minutes 10] [--repeats 3] [--smoke]``.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import signal as sps

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402

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
    ap = parser(__doc__)
    ap.add_argument("--minutes", type=float, default=10.0)
    a = ap.parse_args()
    bench = Bench.from_args("frf", a, repeats=3)
    seconds = 20.0 if a.smoke else a.minutes * 60
    with tempfile.TemporaryDirectory() as d:
        run = Path(d) / "long_random.h5"
        t0 = time.perf_counter()
        write_run(run, seconds)
        written = time.perf_counter() - t0
        frf = str(Path(d) / "frf.json")
        bench.warm_up(lambda: (pipeline(run, frf), core(min(seconds, 20.0))),
                      "one pipeline run in a subprocess and a 20 s core call")
        timing = bench.repeat(lambda: pipeline(run, frf))
        size = run.stat().st_size
    walls = [r[0] for r in timing.results]
    cpus = [r[1] for r in timing.results]
    rss = max(r[2] for r in timing.results)
    rss0 = max(r[3] for r in timing.results)
    modes = timing.result[4]
    repeats = len(walls)
    ratios = sorted(seconds / t for t in walls)
    wall_med, cpu_med = timing.median_of(walls), timing.median_of(cpus)
    core_t = bench.repeat(lambda: core(seconds))
    core_s = timing.median_of(core_t.results)
    print(f"record: {seconds:g} s, 4 channels at {FS:g} S/s ({seconds * FS * 4 / 1e6:.1f} M samples), "
          f"run file {size / 2**20:.0f} MB (written in {written:.1f} s)")
    print(f"modes found (Hz): {modes}  (simulated {[m for m, _ in MODES_HZ]})")
    print(f"`labjoint frf` + `labjoint modes` from the run file: {seconds / wall_med:.0f}x real "
          f"time (median of {repeats}; best {ratios[-1]:.0f}x, worst {ratios[0]:.0f}x), "
          f"{seconds / cpu_med:.0f}x on their CPU time")
    print(f"peak RSS of the process: {rss / 1024:.0f} MB, {rss0 / 1024:.0f} MB of it after the imports "
          f"(the record: {size / 2**20:.0f} MB)")
    print(f"numerical core alone (blocks in memory, float32): {seconds / core_s:.0f}x real time")
    bench.figure("`labjoint frf` + `labjoint modes` from the run file", seconds / wall_med,
                 "real time (the record's duration; after the process's imports)",
                 value=wall_med, unit="s", best=ratios[-1], worst=ratios[0], repeats=repeats)
    bench.figure("`labjoint frf` + `labjoint modes`, CPU time", seconds / cpu_med,
                 "real time, per CPU second of the two commands (less sensitive to load)",
                 value=cpu_med, unit="s CPU")
    bench.figure("peak RSS of the process / record size", rss * 1024 / size,
                 "the run file's size on disk (memory bounded: < 1 for a long record)",
                 value=rss / 1024, unit="MB", rss_after_imports_mb=rss0 / 1024)
    bench.figure("numerical core alone (blocks in memory, float32)", seconds / core_s,
                 "real time (the record's duration)", value=core_s, unit="s",
                 repeats=len(core_t.results))
    bench.finish(record_s=seconds, file_mb=size / 2**20, modes_hz=modes)


if __name__ == "__main__":
    main()
