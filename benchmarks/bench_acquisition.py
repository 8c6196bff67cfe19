"""Acquisition to disk: sustained rate as a multiple of the rig's need, and daemon memory.

The rig needs 4 channels at 50 kS/s (NI 9233), in blocks of 5000 samples (0.1 s).

(a) Sustained rate, each path checked gap-free by reading its file back:
    1. writer: the storage RunWriter fed ready-made blocks as fast as it takes them
       (channel 0 carries the sample index, so the read-back proves no sample was lost,
       repeated or moved);
    2. daemon + synthetic DAQ: the daemon's whole path (queue job, RunEngine with its
       limit checks, RunWriter, run tracker) with a DAQ returning a 400 Hz sine and its
       own sample counter at once (no physics), content checked sample by sample;
    3. daemon + simulated rig: the same with the physics simulator (SimDAQ), which is
       itself the bottleneck.
    Rate = recorded samples per channel / record wall time / 50 kS/s.
(b) Memory: a daemon subprocess (``python -m labjoint.daemon``, simulated rig at 50 kS/s,
    not paced) records a 10-minute dwell as fast as the simulator allows; its RSS is
    sampled from /proc. Flat means samples go to disk, not into a growing list.

Figures: (a) medians of the repeats, each a ratio to the rig's need (real time x 4
channels x 50 kS/s); (b) the RSS slope against keeping the samples (32 MB per million).

Usage: ``.venv/bin/python benchmarks/bench_acquisition.py [--writer-seconds 60]
[--daemon-seconds 60] [--sim-seconds 20] [--minutes 10] [--no-rss] [--repeats 3] [--smoke]``.
"""

from __future__ import annotations

import itertools
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.harness import Bench, parser  # noqa: E402
from labjoint.documents import Block, RunStart, RunStop  # noqa: E402
from labjoint.acquisition.rig import Rig, open_rig  # noqa: E402
from labjoint.config import load_config  # noqa: E402
from labjoint.daemon import Daemon, JobQueue  # noqa: E402
from labjoint.hardware.interfaces import DAQ  # noqa: E402
from labjoint.storage import RunWriter, open_run  # noqa: E402

NEED_HZ = 50_000.0   # per channel, 4 channels
BLOCK = 5000
F0 = 400.0


def _check_read_back(path: Path, n_expected: int, daq: "SyntheticDAQ | None" = None,
                     index_channel: str | None = None) -> None:
    """The file holds n_expected samples and no gap; with ``index_channel`` that channel
    is the sample index; with ``daq`` every sample is what the synthetic DAQ produced."""
    with open_run(path) as rf:
        assert rf.n_samples == n_expected, (rf.n_samples, n_expected)
        assert rf.gaps == [] and rf.metadata["continuous"], rf.gaps
        start = None if daq is None else daq.counter_of(rf.volts(rf.channel_names[0], 0, 1)[0])
        step = 1 << 20
        for a in range(0, n_expected, step):
            b = min(n_expected, a + step)
            if index_channel is not None:
                got = rf.volts(index_channel, a, b)
                assert np.array_equal(got, np.arange(a, b, dtype=float)), f"samples {a}:{b}"
            if daq is not None:
                want = daq.expected(start + a, b - a)
                for row, name in enumerate(rf.channel_names):
                    assert np.array_equal(rf.volts(name, a, b), want[row]), f"{name} {a}:{b}"


def bench_writer(data_dir: Path, seconds: float) -> float:
    """Writer-only rate (multiple of the need); content verified."""
    config = load_config()
    chans = config.daq.specs()
    rng = np.random.default_rng(0)
    noise = rng.normal(0.0, 0.1, (8, len(chans), BLOCK))
    n_blocks = int(seconds * NEED_HZ / BLOCK)
    w = RunWriter(data_dir, flush_interval_s=1.0)
    w("start", RunStart("w", "writer_only", chans, NEED_HZ, {"plan": "bench"}))
    idx = np.arange(BLOCK, dtype=float)
    t0 = time.perf_counter()
    for k in range(n_blocks):
        volts = noise[k % 8]
        volts[0] = idx + k * BLOCK
        w("block", Block("w", k * BLOCK, volts))
    w("stop", RunStop("w", "complete", n_samples=n_blocks * BLOCK))
    dt = time.perf_counter() - t0
    _check_read_back(data_dir / "writer_only.h5", n_blocks * BLOCK, index_channel=chans[0].name)
    return n_blocks * BLOCK / dt / NEED_HZ


class SyntheticDAQ(DAQ):
    """Returns ready-made samples at once: a 400 Hz sine on every channel but the first,
    which carries the DAQ's sample counter (modulo 2**20, as an exact binary fraction of
    a volt), so the read-back can check every sample's place."""

    MOD = 1 << 20

    def __init__(self, channels, rate: float) -> None:
        self._channels, self._rate = list(channels), rate
        t = np.arange(BLOCK) / rate
        gains = np.array([0.0, 1.0, -1.0, 0.2])[: len(channels), None]
        self.template = gains * np.sin(2 * np.pi * F0 * t)[None, :]
        self._n = 0

    def expected(self, first: int, n: int) -> np.ndarray:
        """The samples ``first .. first + n`` (counted from the DAQ start)."""
        reps = -(-(first % BLOCK + n) // BLOCK)
        a = first % BLOCK
        out = np.tile(self.template, reps)[:, a:a + n] if reps > 1 else self.template[:, a:a + n].copy()
        out[0] = (np.arange(first, first + n) % self.MOD) * (1.0 / self.MOD)
        return out

    def counter_of(self, value: float) -> int:
        return int(round(value * self.MOD))

    def configure(self, channels, sample_rate_hz):
        return self._rate

    @property
    def channels(self):
        return self._channels

    @property
    def sample_rate_hz(self):
        return self._rate

    def start(self):
        self._n = 0

    def read(self, n_samples, out=None):
        volts = self.expected(self._n, n_samples)
        self._n += n_samples
        return volts

    @property
    def samples_read(self):
        return self._n

    def stop(self):
        pass

    def close(self):
        pass


def _record_wall_s(path: Path) -> float:
    with open_run(path) as rf:
        start = datetime.fromisoformat(rf.metadata["start_time"])
        end = datetime.fromisoformat(rf.end_time)
    return (end - start).total_seconds()


def bench_daemon(data_dir: Path, seconds: float, synthetic: bool) -> tuple[float, float]:
    """(record rate as a multiple of the need, simulated s per wall s overall)."""
    config = load_config()
    daq_holder: dict = {}

    def factory(cfg):
        rig = open_rig(cfg)
        if not synthetic:
            daq_holder["daq"] = rig.daq
            return rig
        rig.daq.close()
        daq = SyntheticDAQ(cfg.daq.specs(), cfg.daq.sample_rate_hz)
        daq_holder["daq"] = daq
        return Rig(cfg, rig.generator, daq, None)

    n_cycles = int(seconds * F0)
    with Daemon(config, data_dir, poll_s=0.2, rig_factory=factory) as daemon:
        daemon.queue.submit({"plan": "dwell", "frequency_hz": F0, "amplitude_vpp": 2.0,
                             "n_cycles": n_cycles})
        t0 = time.perf_counter()
        job = daemon.run_one()
        total = time.perf_counter() - t0
    assert job.status == "done", job.message
    path = data_dir / f"{job.runs[0]}.h5"
    n = math.ceil(n_cycles * NEED_HZ / F0)
    daq = daq_holder["daq"]
    _check_read_back(path, n, daq=daq if synthetic else None)
    acquired = daq.samples_read / NEED_HZ  # since the last start: steady wait + record
    return n / _record_wall_s(path) / NEED_HZ, acquired / total


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmRSS")


def bench_rss(data_dir: Path, minutes: float) -> dict:
    """RSS of a daemon process over a ``minutes``-long simulated dwell at 50 kS/s."""
    queue = JobQueue(data_dir / "queue.sqlite")
    job_id = queue.submit({"plan": "dwell", "frequency_hz": F0, "amplitude_vpp": 2.0,
                           "n_cycles": int(minutes * 60 * F0)})
    proc = subprocess.Popen([sys.executable, "-m", "labjoint.daemon", "--data-dir", str(data_dir)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    samples: list[tuple[float, float, int]] = []  # (t, rss MB, run samples)
    t0 = time.perf_counter()
    try:
        while True:
            job = queue.get(job_id)
            if job.finished:
                break
            if proc.poll() is not None:
                raise RuntimeError(f"daemon exited with {proc.returncode}")
            st = queue.daemon_status() or {}
            samples.append((time.perf_counter() - t0, _rss_mb(proc.pid),
                            int(st.get("samples") or 0)))
            time.sleep(0.5)
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=60)
    assert job.status == "done", job.message
    path = data_dir / f"{job.runs[0]}.h5"
    n = math.ceil(minutes * 60 * NEED_HZ)
    _check_read_back(path, n)
    recording = [s for s in samples if s[2] > 0] or samples     # a short run: any reading
    if not recording:                                          # too short for one reading
        recording = [(0.0, float("nan"), 0)]
    rss = np.array([s[1] for s in recording])
    done = np.array([s[2] for s in recording], dtype=float)
    late = done >= done[-1] / 2
    spread = late.sum() > 2 and np.ptp(done[late]) > 0           # readings while it recorded
    slope = np.polyfit(done[late] / 1e6, rss[late], 1)[0] if spread else float("nan")
    quarters = [float(np.interp(q * done[-1], done, rss)) if spread else float("nan")
                for q in (0.25, 0.5, 0.75)]
    return {"start_mb": rss[0], "peak_mb": rss.max(), "end_mb": rss[-1], "quarters": quarters,
            "slope_mb_per_msample": slope, "wall_s": _record_wall_s(path), "n_samples": n,
            "data_mb": 4 * n * 8 / 2**20, "file_mb": path.stat().st_size / 2**20,
            "n_rss_samples": len(rss)}


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--writer-seconds", type=float, default=60.0)
    ap.add_argument("--daemon-seconds", type=float, default=60.0)
    ap.add_argument("--sim-seconds", type=float, default=20.0)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--no-rss", action="store_true")
    args = ap.parse_args(argv)
    if args.smoke:
        args.writer_seconds, args.daemon_seconds, args.sim_seconds, args.minutes = 0.5, 0.5, 0.2, 0.05
    bench = Bench.from_args("acquisition", args, repeats=3)
    print("need: 4 channels x 50 kS/s; target >= 20x", flush=True)
    need = "the rig's need (4 channels x 50 kS/s in real time)"
    with tempfile.TemporaryDirectory(prefix="bench_acq_") as tmp:
        tmp = Path(tmp)
        k = itertools.count()
        bench.warm_up(lambda: bench_daemon(tmp / "warm", 0.1, synthetic=False),
                      "a 0.1 s daemon run on the simulated rig")
        t = bench.repeat(lambda: bench_writer(tmp / f"w{next(k)}", args.writer_seconds))
        r = t.median_of(t.results)
        bench.figure(f"(a1) writer only, {args.writer_seconds:g} s of data, no gaps", r, need,
                     target=">= 20", per_repeat=t.results)
        t = bench.repeat(lambda: bench_daemon(tmp / f"s{next(k)}", args.daemon_seconds,
                                              synthetic=True)[0])
        r = t.median_of(t.results)
        bench.figure(f"(a2) daemon + synthetic DAQ, {args.daemon_seconds:g} s, content exact",
                     r, need, target=">= 20", per_repeat=t.results)
        t = bench.repeat(lambda: bench_daemon(tmp / f"p{next(k)}", args.sim_seconds,
                                              synthetic=False))
        rs = sorted(x[0] for x in t.results)
        ov = sorted(x[1] for x in t.results)
        bench.figure(f"(a3) daemon + simulated rig, {args.sim_seconds:g} s, while recording",
                     t.median_of(rs), need, per_repeat=rs)
        bench.figure("(a3) daemon + simulated rig, whole job", t.median_of(ov), "real time",
                     per_repeat=ov)
        if not args.no_rss:
            m = bench_rss(tmp / "m", args.minutes)
            q = ", ".join(f"{x:.0f}" for x in m["quarters"])
            print(f"(b) daemon RSS over a {args.minutes:g}-minute simulated run "
                  f"({m['wall_s']:.0f} s wall, {m['n_samples'] / 1e6:.0f} M samples/channel, "
                  f"{m['data_mb']:.0f} MB of samples, file {m['file_mb']:.0f} MB, "
                  f"{m['n_rss_samples']} readings): start {m['start_mb']:.0f} MB, "
                  f"at 1/4, 1/2, 3/4: {q} MB, end {m['end_mb']:.0f} MB, peak "
                  f"{m['peak_mb']:.0f} MB", flush=True)
            slope = m["slope_mb_per_msample"]
            bench.figure("(b) daemon RSS slope over the second half", slope / 32.0 if
                         slope == slope else 0.0, "keeping the samples (32 MB per million "
                         "samples/channel); 0 = flat", value=slope, unit="MB per M samples",
                         peak_mb=m["peak_mb"], start_mb=m["start_mb"], end_mb=m["end_mb"])
    bench.finish()
    return 0


if __name__ == "__main__":
    sys.exit(main())
