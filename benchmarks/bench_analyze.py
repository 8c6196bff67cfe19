"""Hysteresis-loop analysis: speed (multiple of real time) and peak memory when streamed.

(a) A 60 s, 4-channel, 50 kS/s record (microslip Iwan-type joint force from rest, viscous
    part, slow wear drift, sensor noise and offsets) is written as a labjoint run file
    (storage RunWriter; a plain h5py file if the storage layer is missing) and analysed by
    ``identify.analyze_file``, the pipeline of ``labjoint analyze`` (reads the three
    channels the loop needs, checks the excitation on the reference force, filters,
    segments, measures every cycle), seven times: record length / wall time = "x real
    time", median, best and worst. The same record read by this script (all 4 channels)
    and analysed from blocks, and from blocks already in memory, is timed too.
(b) The same kind of record lasting 10 minutes (960 MB as float64) is analysed from its
    file in blocks by a fresh subprocess, which reports its peak RSS (ru_maxrss).

Reference in the same process: scipy's ``sosfiltfilt`` (the paper's 5th-order 3 kHz
Butterworth) of the same three channels, in memory, alone: analyze / scipy says what the
whole pipeline (reading, excitation check, filter, cycles, loop metrics) costs against
the bare filter it contains. CPU time (all threads) is printed beside the wall time.

Every step runs in its own subprocess and this parent imports only the standard library:
Linux carries a parent's ru_maxrss into a forked child, so a small parent keeps the
child's figure its own (VmHWM from /proc is printed as a cross-check).

Usage: ``.venv/bin/python benchmarks/bench_analyze.py [--seconds 60] [--minutes 10]
[--repeats 7] [--smoke]``.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402

FS, F0 = 50_000.0, 400.0
WRITE_BLOCK = 1 << 17                         # samples per written block
READ_BLOCK = 1 << 18                          # samples per analysed block
REPEATS = 7                                   # timings of labjoint's own file pipeline
SENS = {"force_ref": 50.0, "disp_1": 1.25e-5, "disp_2": 1.25e-5, "shear_nc": 301.0}


def synth_blocks(seconds: float, seed: int = 0, fs: float = FS):
    """Yield (first_sample, volts (4, n)): 20 Jenkins elements in parallel (Iwan, 10 MN/m,
    slip displacements 0.5-14 um) + 2 MN/m + 600 Ns/m, 9 um from rest (tau 20 ms),
    5 % wear drift over the run, noise 0.4 % of U per displacement sensor and 0.4 N."""
    import numpy as np
    from numba import njit

    @njit
    def iwan(u, k, slip, z):  # pragma: no cover - compiled
        out = np.empty_like(u)
        for i in range(u.size):
            total = 0.0
            for j in range(k.size):
                d = u[i] - z[j]
                if d > slip[j]:
                    z[j] = u[i] - slip[j]
                    d = slip[j]
                elif d < -slip[j]:
                    z[j] = u[i] + slip[j]
                    d = -slip[j]
                total += k[j] * d
            out[i] = total
        return out

    k_el, slip, z = np.full(20, 1.0e7 / 20), np.linspace(0.5e-6, 14e-6, 20), np.zeros(20)
    rng = np.random.default_rng(seed)
    n_total, omega = int(seconds * fs), 2 * np.pi * F0
    U, tau, wear = 9e-6, 0.02, 0.05
    for first in range(0, n_total, WRITE_BLOCK):
        t = (first + np.arange(min(WRITE_BLOCK, n_total - first))) / fs
        env = (1 - np.exp(-t / tau)) * (1 - wear * t / seconds)
        u = U * env * np.sin(omega * t)
        F = iwan(u, k_el, slip, z) + 2.0e6 * u + 600.0 * U * env * omega * np.cos(omega * t)
        d1 = 0.5 * u + 5e-5 + 0.004 * U * rng.standard_normal(t.size)
        d2 = -0.5 * u - 3e-5 + 0.004 * U * rng.standard_normal(t.size)
        f_ref = 1.04 * F + 0.4 * rng.standard_normal(t.size)
        f_nc = F + 0.4 * rng.standard_normal(t.size)
        yield first, np.stack([f_ref / SENS["force_ref"], d1 / SENS["disp_1"],
                               d2 / SENS["disp_2"], f_nc / SENS["shear_nc"]])


def write_run(directory: Path, name: str, seconds: float, fs: float = FS) -> tuple[Path, str]:
    """Write the synthetic record as a labjoint run file (or a plain h5py file)."""
    try:
        from labjoint.documents import Block, RunStart, RunStop
        from labjoint.hardware.interfaces import ChannelSpec
        from labjoint.storage.writer import RunWriter
    except ImportError as exc:                            # storage layer not there yet
        import h5py

        path, n = directory / f"{name}.h5", int(seconds * fs)
        with h5py.File(path, "w") as f:
            ds = {c: f.create_dataset(c, (n,), "f8", chunks=(32768,)) for c in SENS}
            for first, volts in synth_blocks(seconds, fs=fs):
                for c, row in zip(SENS, volts):
                    ds[c][first:first + row.size] = row
        return path, f"plain h5py file ({exc})"
    chans = [ChannelSpec("force_ref", "force", "force", "N", SENS["force_ref"], iepe=True),
             ChannelSpec("disp_1", "capacitive", "displacement", "m", SENS["disp_1"]),
             ChannelSpec("disp_2", "capacitive", "displacement", "m", SENS["disp_2"]),
             ChannelSpec("shear_nc", "nanocomposite", "force", "N", SENS["shear_nc"])]
    uid = uuid.uuid4().hex
    md = {"frequency_hz": F0, "joint_force_channel": "shear_nc",
          "displacement_channels": ["disp_1", "disp_2"]}
    with RunWriter(directory, flush_interval_s=1e9) as writer:
        writer("start", RunStart(uid, name, chans, fs, md))
        for first, volts in synth_blocks(seconds, fs=fs):
            writer("block", Block(uid, first, volts))
        path = writer.stop(RunStop(uid, "complete", n_samples=int(seconds * fs)))
    return Path(path), "labjoint run file, storage.writer"


def stream_blocks(path: Path, with_time_axis: bool = False):
    """(displacement m, force N) blocks from the file, all 4 channels read and calibrated.

    ``with_time_axis`` reads through ``RunFile.iter_blocks`` (which also decompresses
    the time axis); otherwise each channel is read with ``RunFile.physical``.
    """
    import h5py

    with h5py.File(path, "r") as probe:
        is_run = "entry" in probe
    if not is_run:                                        # plain h5py fallback file
        with h5py.File(path, "r") as f:
            for a in range(0, f["disp_1"].shape[0], READ_BLOCK):
                d = {c: f[c][a:a + READ_BLOCK] * SENS[c] for c in SENS}
                yield d["disp_1"] - d["disp_2"], d["shear_nc"]
        return
    from labjoint.storage.reader import open_run

    with open_run(path) as rf:
        if with_time_axis:
            blocks = (blk.data for blk in rf.iter_blocks(READ_BLOCK))
        else:
            blocks = ({c: rf.physical(c, a, a + READ_BLOCK) for c in rf.channel_names}
                      for a in range(0, rf.n_samples, READ_BLOCK))
        for d in blocks:
            yield d["disp_1"] - d["disp_2"], d["shear_nc"]


def _timed(fn) -> tuple[float, object]:
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def child_speed(path: str, seconds: float, repeats: int = REPEATS) -> dict:
    """Read-only, read + analyse (two read paths), and analyse-only timings; the scipy
    reference (sosfiltfilt of the three channels in memory), alternating with the
    pipeline's repeats so that both see the same load."""
    import numpy as np
    from scipy.signal import butter, sosfiltfilt

    from labjoint.identify.analyze import analyze_arrays, analyze_blocks, analyze_file
    from labjoint.signal.filter import PAPER_CUTOFF_HZ, PAPER_ORDER
    from labjoint.storage.reader import open_run

    p = Path(path)
    t = np.arange(20_000) / FS                            # load numba caches, scipy
    t0 = time.perf_counter()
    analyze_arrays(1e-6 * np.sin(2 * np.pi * F0 * t), np.cos(2 * np.pi * F0 * t), FS, F0)
    warm_s = time.perf_counter() - t0
    with open_run(p) as rf:
        three = np.stack([rf.physical(c, 0, rf.n_samples)
                          for c in ("disp_1", "disp_2", "shear_nc")])
    sos = butter(PAPER_ORDER, PAPER_CUTOFF_HZ, fs=FS, output="sos")
    sosfiltfilt(sos, three[:, :1000], axis=-1)
    files, cpus, scipy_s = [], [], []
    for _ in range(repeats):
        c0 = time.process_time()
        files.append(_timed(lambda: analyze_file(p))[0])
        cpus.append(time.process_time() - c0)
        scipy_s.append(_timed(lambda: sosfiltfilt(sos, three, axis=-1))[0])
    files.sort()
    t_read, _ = _timed(lambda: sum(u.size for u, _ in stream_blocks(p)))
    t_iter, _ = _timed(lambda: sum(u.size for u, _ in stream_blocks(p, True)))
    cpu0 = time.process_time()
    t_all, res = _timed(lambda: analyze_blocks(stream_blocks(p), FS, F0))
    cpu = time.process_time() - cpu0
    t_all_iter, _ = _timed(lambda: analyze_blocks(stream_blocks(p, True), FS, F0))
    blocks = list(stream_blocks(p))
    t_mem, _ = _timed(lambda: analyze_blocks(iter(blocks), FS, F0))
    return {"file_s": files, "file_cpu_s": sorted(cpus), "scipy_s": sorted(scipy_s),
            "warm_up_s": warm_s, "read_s": t_read, "read_iter_blocks_s": t_iter, "total_s": t_all, "cpu_s": cpu,
            "total_iter_blocks_s": t_all_iter, "analyse_only_s": t_mem,
            "summary": res.summary, "steady_start": res.steady_state.start,
            "n_cycles": res.n_cycles, "seconds": seconds}


def child_memory(path: str) -> dict:
    """Analyse ``path`` streamed; peak RSS of this process (ru_maxrss and VmHWM)."""
    import labjoint.identify.analyze as an

    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    elapsed, res = _timed(lambda: an.analyze_blocks(stream_blocks(Path(path)), FS, F0))
    hwm = next((int(line.split()[1]) / 1024 for line in open("/proc/self/status")
                if line.startswith("VmHWM")), float("nan"))
    return {"after_imports_mb": base, "ru_maxrss_mb": resource.getrusage(
        resource.RUSAGE_SELF).ru_maxrss / 1024, "vmhwm_mb": hwm, "total_s": elapsed,
        "n_cycles": res.n_cycles, "damping": res.summary["damping_ns_per_m"]}


def _child(*args: str) -> dict:
    proc = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"subprocess {args[0]} failed:\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv: list[str]) -> int:
    ap = parser(__doc__)
    ap.add_argument("--seconds", type=float, default=60.0, help="(a) record length, s")
    ap.add_argument("--minutes", type=float, default=10.0, help="(b) record length, min")
    ap.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        kind, *rest = args.child
        if kind == "write":
            t, (path, how) = _timed(lambda: write_run(Path(rest[0]), rest[1], float(rest[2])))
            out = {"path": str(path), "how": how, "write_s": t}
        elif kind == "speed":
            out = child_speed(rest[0], float(rest[1]), int(rest[2]))
        else:
            out = child_memory(rest[0])
        print(json.dumps(out))
        return 0
    if args.smoke:
        args.seconds, args.minutes = 2.0, 0.05
    bench = Bench.from_args("analyze", args, repeats=REPEATS)
    with tempfile.TemporaryDirectory(prefix="bench_analyze_") as tmp:
        w = _child("--child", "write", tmp, "speed", str(args.seconds))
        size = Path(w["path"]).stat().st_size / 1e6
        print(f"wrote {args.seconds:g} s x 4 channels x {FS:g} S/s ({w['how']}, {size:.0f} MB)")
        s = _child("--child", "speed", w["path"], str(args.seconds), str(bench.repeats))
        bench.numba = (f"compilation excluded: warm-up call (analyze_arrays on a 20,000-sample "
                       f"sine) before timing, {s['warm_up_s']:.2f} s (kernels with cache=True)")
        fs_, cpu_, sp_ = s["file_s"], s["file_cpu_s"], s["scipy_s"]
        med, cpu_med, sp_med = fs_[len(fs_) // 2], cpu_[len(cpu_) // 2], sp_[len(sp_) // 2]
        print(f"(a) labjoint analyze's pipeline (identify.analyze_file: 3 channels read, "
              f"excitation check, filter, cycles) on {args.seconds:g} s: median "
              f"{med:.3f} s, best {args.seconds / fs_[0]:.0f}x, worst "
              f"{args.seconds / fs_[-1]:.0f}x over {len(fs_)} runs; CPU (all threads) "
              f"median {cpu_med:.3f} s")
        bench.figure("(a) analyze_file", args.seconds / med, "real time", value=med, unit="s",
                     target=">= 500", median_of=len(fs_), best_x=args.seconds / fs_[0],
                     worst_x=args.seconds / fs_[-1])
        bench.figure("(a) analyze_file CPU time", args.seconds / cpu_med,
                     "real time, per CPU second (all threads; less sensitive to load)",
                     value=cpu_med, unit="s CPU")
        bench.figure("(a) analyze_file / scipy sosfiltfilt", med / sp_med,
                     "scipy sosfiltfilt of the same 3 channels in memory (order 5, 3 kHz), "
                     "alternating with it", value=sp_med, unit="s (scipy)")
        x = args.seconds / s["total_s"]
        print(f"    this script's own reader (all 4 channels) + analyze_blocks: "
              f"{s['total_s']:.2f} s = {x:.0f}x real time")
        print(f"    of which reading 4 channels: {s['read_s']:.2f} s; analysis alone "
              f"{s['analyse_only_s']:.2f} s = {args.seconds / s['analyse_only_s']:.0f}x real time")
        print(f"    via RunFile.iter_blocks (also decompresses the time axis): read "
              f"{s['read_iter_blocks_s']:.2f} s, read + analyse {s['total_iter_blocks_s']:.2f} s"
              f" = {args.seconds / s['total_iter_blocks_s']:.0f}x")
        m = s["summary"]
        print(f"    {s['n_cycles']} cycles, steady from {s['steady_start']}: W_d "
              f"{m['energy_loss_j'] * 1e3:.4f} mJ, C {m['damping_ns_per_m']:.0f} Ns/m, "
              f"k {m['stiffness_n_per_m'] / 1e6:.2f} MN/m")
        Path(w["path"]).unlink()
        w = _child("--child", "write", tmp, "memory", str(args.minutes * 60))
        size = Path(w["path"]).stat().st_size / 1e6
        print(f"wrote {args.minutes:g} min x 4 channels ({size:.0f} MB on disk; float64 in "
              f"memory {args.minutes * 60 * FS * 4 * 8 / 1e6:.0f} MB) in {w['write_s']:.0f} s")
        r = _child("--child", "memory", w["path"])
        print(f"(b) peak RSS streaming {args.minutes:g} min: ru_maxrss {r['ru_maxrss_mb']:.0f} MB "
              f"(VmHWM {r['vmhwm_mb']:.0f} MB; {r['after_imports_mb']:.0f} MB after imports); "
              f"{r['total_s']:.1f} s = {args.minutes * 60 / r['total_s']:.0f}x real time, "
              f"{r['n_cycles']} cycles")
        bench.figure("(b) peak RSS streaming / 500 MB", r["ru_maxrss_mb"] / 500.0,
                     "the 500 MB memory goal", value=r["ru_maxrss_mb"], unit="MB",
                     target="<= 1", minutes=args.minutes)
    bench.finish(seconds=args.seconds, minutes=args.minutes, n_cycles=s["n_cycles"],
                 energy_loss_j=m["energy_loss_j"])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
