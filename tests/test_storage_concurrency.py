"""Concurrent reads of a run return exactly the stored samples (issue 12 item 1)."""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from labjoint.documents import Block, RunStart, RunStop
from labjoint.storage import open_run
from labjoint.storage.writer import RunWriter
from test_storage_fixtures import FS, rig_channels
from patience import http_client

N = 400_000
THREADS, WINDOWS = 16, 64


def _volts(n: int, seed: int = 0) -> np.ndarray:
    """Four channels whose every sample is distinct (index-coded), so a wrong window shows."""
    k = np.arange(n, dtype=float)
    return np.stack([1e-6 * k + 0.1 * c for c in range(4)]) * (1 + 1e-3 * np.random.default_rng(seed).random((4, n)))


def _windows(n: int, seed: int) -> list[tuple[int, int]]:
    rng = np.random.default_rng(seed)
    starts = rng.integers(0, n - 1, WINDOWS)
    lens = rng.integers(1, 40_000, WINDOWS)                   # many cross 32,768-sample chunks
    return [(int(a), int(min(n, a + m))) for a, m in zip(starts, lens)]


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("conc")
    volts = _volts(N)
    w = RunWriter(d)
    w("start", RunStart("uid-c", "conc", rig_channels(), FS, {"frequency_hz": 400.0}))
    for a in range(0, N, 20_000):
        w("block", Block("uid-c", a, volts[:, a:a + 20_000]))
    w("stop", RunStop("uid-c", "complete", n_samples=N))
    return d / "conc.h5", volts


def _read(path, a, b):
    with open_run(path) as rf:
        return rf.time(a, b), np.stack([rf.volts(c, a, b) for c in rf.channel_names])


@pytest.mark.slow        # end to end, 40-120 s on a busy machine (issue 31)
def test_sixteen_threads_read_exactly_what_serial_reads_do(run_file):
    path, volts = run_file
    jobs = [w for s in range(THREADS) for w in _windows(N, s)]
    serial = [_read(path, a, b) for a, b in jobs]
    barrier = threading.Barrier(THREADS)

    def worker(s):
        barrier.wait()
        return [_read(path, a, b) for a, b in _windows(N, s)]

    with ThreadPoolExecutor(THREADS) as ex:
        got = [r for part in ex.map(worker, range(THREADS)) for r in part]
    for (a, b), (t, v), (t0, v0) in zip(jobs, got, serial):
        assert t.tobytes() == t0.tobytes(), (a, b)
        assert v.tobytes() == v0.tobytes() == volts[:, a:b].tobytes(), (a, b)


@pytest.mark.slow        # end to end, 40-120 s on a busy machine (issue 31)
def test_rest_data_endpoint_under_concurrency(run_file):
    
    from labjoint.api import ApiSettings, create_app
    from labjoint.storage import Catalog
    from test_api_helpers import READ, READ_AUTH, live_server

    path, volts = run_file
    Catalog(path.parent / "catalog.sqlite").rebuild(path.parent)
    app = create_app(ApiSettings(data_dir=path.parent, read_tokens=[READ]))
    jobs = [w for s in range(THREADS) for w in _windows(N, 100 + s)][:THREADS * 4]
    with live_server(app) as url:
        def get(win):
            a, b = win
            with http_client(url + "/api/v1", headers=READ_AUTH) as http:
                r = http.get("/runs/conc/data", params={
                    "start": a, "stop": b, "unit": "samples", "max_points": 5_000,
                    "channel": ["disp_1", "force_ref"]})
            assert r.status_code == 200, r.text
            return r.json()

        serial = [get(w) for w in jobs]
        with ThreadPoolExecutor(THREADS) as ex:
            got = list(ex.map(get, jobs))
    assert got == serial
    for (a, b), body in zip(jobs, got):                     # and they are the stored ones
        s = body["series"][0]
        idx = np.rint(np.asarray(s["time_s"]) * FS).astype(int)
        assert idx.min() >= a and idx.max() < b
        assert s["values"] == pytest.approx((volts[1, idx] * 1.25e-5).tolist(), rel=1e-12)


def _readers_while(path, volts, writing, n_threads=THREADS):
    """16 threads read windows within what is visible until ``writing`` ends; every
    window must equal the final data. Returns the number of windows checked."""
    checked = []

    def worker(s):
        rng = np.random.default_rng(1000 + s)
        n_done = 0
        while writing.is_alive() or n_done < 8:
            try:
                with open_run(path) as rf:
                    n = rf.n_samples
                    if n < 2:
                        continue
                    a = int(rng.integers(0, n - 1))
                    b = int(min(n, a + rng.integers(1, 70_000)))
                    t, v = rf.time(a, b), np.stack([rf.volts(c, a, b) for c in rf.channel_names])
            except Exception as exc:          # the file may not exist yet at the very start
                if "no such run file" in str(exc):
                    continue
                raise
            assert v.tobytes() == volts[:, a:b].tobytes(), (a, b, n)
            assert np.array_equal(t, (a + np.arange(b - a)) / FS), (a, b, n)
            n_done += 1
        checked.append(n_done)

    threads = [threading.Thread(target=worker, args=(s,)) for s in range(n_threads)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return sum(checked)


def test_reads_while_this_process_appends(tmp_path):
    volts = _volts(N, seed=3)
    path = tmp_path / "live.h5"
    w = RunWriter(tmp_path, flush_interval_s=0.0)
    w("start", RunStart("uid-l", "live", rig_channels(), FS, {"frequency_hz": 400.0}))

    def write():
        for a in range(0, N, 5_000):
            w("block", Block("uid-l", a, volts[:, a:a + 5_000]))
        w("stop", RunStop("uid-l", "complete", n_samples=N))

    writer = threading.Thread(target=write)
    writer.start()
    assert _readers_while(path, volts, writer) >= THREADS * 8


def test_reads_while_another_process_appends(tmp_path):
    import subprocess
    import sys

    volts = _volts(N, seed=4)
    np.save(tmp_path / "volts.npy", volts)
    code = f"""
import sys, time, numpy as np
sys.path.insert(0, {str(__import__('pathlib').Path(__file__).parent)!r})
from labjoint.documents import Block, RunStart, RunStop
from labjoint.storage.writer import RunWriter
from test_storage_fixtures import FS, rig_channels
v = np.load({str(tmp_path / 'volts.npy')!r})
w = RunWriter({str(tmp_path)!r}, flush_interval_s=0.0)
w("start", RunStart("uid-p", "proc", rig_channels(), FS, {{"frequency_hz": 400.0}}))
for a in range(0, v.shape[1], 10_000):
    w("block", Block("uid-p", a, v[:, a:a + 10_000]))
    time.sleep(0.01)
w("stop", RunStop("uid-p", "complete", n_samples=v.shape[1]))
"""
    proc = subprocess.Popen([sys.executable, "-c", code])

    class _Alive:
        def is_alive(self):
            return proc.poll() is None

    checked = _readers_while(tmp_path / "proc.h5", volts, _Alive())
    assert proc.wait() == 0 and checked >= THREADS * 8
