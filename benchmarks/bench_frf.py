"""FRF and modes of a long broadband record: speed as a multiple of real time, memory bounded.

A 10-minute, 4-channel (a drive and three responses), 51.2 kS/s record of a 2-DOF
structure under random force is processed as ``labjoint frf`` + ``labjoint modes`` do (in single precision here):
Welch sums accumulated block by block (:class:`labjoint.signal.spectra.Welch`, segments
of 2^16 samples at half overlap, as :func:`labjoint.signal.broadband.segment_length`
chooses for such a record), then H1/H2/Hv, coherence, random errors, and the automatic
LSCF/LSFD mode selection (:func:`labjoint.identify.modes.find_modes`) over 5-300 Hz.

The record is streamed from a pool of pre-computed blocks of 2^20 samples (the same
samples repeat; generating 123 M random samples is not what is timed), so the working
set is the pool plus one block's segments, whatever the record's length. Printed: record
length / wall time ("x real time"), median over repeats with best and worst, the peak
RSS of this process, and the load average before and after.

Usage: ``python benchmarks/bench_frf.py [--minutes 10] [--repeats 3] [--smoke]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import time

import numpy as np
from scipy import signal as sps

FS = 51_200.0
BLOCK = 1 << 20
POOL = 4


def pool(seed: int = 0) -> list[np.ndarray]:
    """POOL blocks (4, BLOCK): force and three responses of a 2-DOF chain (20, 55 Hz)
    plus a 180 Hz mode, through stable IIR filters, with sensor noise."""
    rng = np.random.default_rng(seed)
    f = rng.normal(size=POOL * BLOCK)
    out = [f]
    for fn, z in [(20.0, 0.02), (55.0, 0.015), (180.0, 0.01)]:
        w = 2 * np.pi * fn
        b, a = sps.bilinear([1.0, 0.0], [1.0, 2 * z * w, w * w], FS)
        out.append(sps.lfilter(b, a, f) + 1e-3 * rng.normal(size=f.size))
    x = np.vstack(out)
    # the three "sensors" see every mode: mix the single-mode responses
    x[1:] = np.array([[1.0, 0.6, 0.3], [0.8, -0.5, 0.4], [0.5, -0.9, -0.6]]) @ x[1:]
    return [x[:, i * BLOCK:(i + 1) * BLOCK].astype(np.float32) for i in range(POOL)]


def one(blocks: list[np.ndarray], seconds: float) -> tuple[float, float, list[float]]:
    from labjoint.identify.modes import find_modes
    from labjoint.signal.broadband import segment_length
    from labjoint.signal.spectra import Welch

    n = int(seconds * FS)
    L, ov = segment_length(n, FS)
    t0, c0 = time.perf_counter(), time.process_time()
    w = Welch(L, FS, 3, overlap=ov, dtype=np.float32)
    done = 0
    i = 0
    while done < n:
        b = blocks[i % len(blocks)]
        k = min(BLOCK, n - done)
        w.feed(b[0, :k], b[1:, :k])
        done += k
        i += 1
    e = w.estimates()
    fr = w.freq_hz
    modes = find_modes(fr, e["H1"], "displacement", ["a", "b", "c"], (5.0, 300.0))
    return (time.perf_counter() - t0, time.process_time() - c0,
            [round(m["frequency_hz"], 3) for m in modes])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--smoke", action="store_true", help="a 20 s record, one repeat (CI)")
    a = ap.parse_args()
    seconds = 20.0 if a.smoke else a.minutes * 60
    repeats = 1 if a.smoke else a.repeats
    load0 = os.getloadavg()
    blocks = pool()
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    times, cpu = [], []
    for _ in range(repeats):
        dt, dc, modes = one(blocks, seconds)
        times.append(dt)
        cpu.append(dc)
    rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    ratios = sorted(seconds / t for t in times)
    print(f"record: {seconds:g} s, 4 channels at {FS:g} S/s ({seconds * FS * 4 / 1e6:.1f} M samples)")
    print(f"modes found (Hz): {modes}  (simulated 20, 55, 180)")
    print(f"FRF + modes: {statistics.median(ratios):.0f}x real time (wall) (median of {repeats}; "
          f"best {ratios[-1]:.0f}x, worst {ratios[0]:.0f}x); on CPU time "
          f"{seconds / statistics.median(cpu):.0f}x (the machine is shared: wall time waits for it)")
    print(f"peak RSS: {rss1 / 1024:.0f} MB (pool of {POOL} blocks: {POOL * BLOCK * 4 * 8 / 2**20:.0f} MB; "
          f"{rss0 / 1024:.0f} MB before the runs)")
    print(f"load average before {load0[0]:.2f}, after {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
