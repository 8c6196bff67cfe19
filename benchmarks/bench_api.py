"""REST latency: GET /api/v1/runs/{name} with 1,000 runs catalogued, 20 concurrent clients.

The service runs as ``labjoint serve`` does (one uvicorn process, reads open, bound to
127.0.0.1) in a subprocess; the catalog holds 1,000 runs (copies of one real run file
written by the storage layer, each catalogued under its own name and conditions). 20
clients on loopback, each on its own keep-alive connection, ask for random runs'
summaries back to back; each request's latency is measured from sending the request to
the last body byte. The clients speak HTTP/1.1 over raw asyncio streams, so the figures
are the server's, not an HTTP library's. Target: p99 <= 50 ms.

Usage: ``.venv/bin/python benchmarks/bench_api.py [--runs 1000] [--clients 20]
[--requests 300]`` (requests per client, after 20 warm-up requests each).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_P99_S = 0.050
HERE = Path(__file__).resolve().parent


def make_catalog(data_dir: Path, n_runs: int) -> list[str]:
    """``n_runs`` catalogued run files in ``data_dir`` (a sweep over Vpp and torque)."""
    import numpy as np

    from labjoint.documents import Block, RunStart, RunStop
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage import Catalog, open_run
    from labjoint.storage.catalog import record_from_run
    from labjoint.storage.writer import RunWriter

    fs, n = 10000.0, 4000
    t = np.arange(n) / fs
    u = 5e-6 * np.sin(2 * np.pi * 400 * t)
    chans = [ChannelSpec("disp_1", "capacitive", "displacement", "m", 1.25e-5),
             ChannelSpec("disp_2", "capacitive", "displacement", "m", 1.25e-5),
             ChannelSpec("shear_nc", "nanocomposite", "force", "N", 301.0)]
    volts = np.stack([u / 2 / 1.25e-5, -u / 2 / 1.25e-5, 1e7 * u / 301.0])
    template_dir = data_dir / "template"
    w = RunWriter(template_dir)
    w("start", RunStart("uid-template", "template", chans, fs,
                        {"frequency_hz": 400.0, "plan": "amplitude_sweep"}))
    w("block", Block("uid-template", 0, volts))
    w("stop", RunStop("uid-template", "complete", n_samples=n))
    with open_run(template_dir / "template.h5") as rf:
        base = record_from_run(rf)
    cat = Catalog(data_dir / "catalog.sqlite")
    names = []
    with cat._connect() as con:
        for i in range(n_runs):
            name = f"bench_{i:04d}_{1 + i % 20}Vpp"
            path = data_dir / f"{name}.h5"
            shutil.copyfile(template_dir / "template.h5", path)
            base.name, base.path, base.uid = name, str(path.resolve()), f"uid-{i}"
            base.excitation_vpp, base.torque_nm = float(1 + i % 20), float(3 + (i // 20) % 6)
            base.normal_force_n = 478.0 * base.torque_nm
            base.start_time = f"2024-01-{1 + i % 28:02d}T{i % 24:02d}:00:00+00:00"
            base.plan_step = i % 20
            cat.put(base, con)
            names.append(name)
    shutil.rmtree(template_dir)
    assert len(cat) == n_runs
    return names


def _cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def serve(data_dir: str, port: int) -> None:
    """Child process: the API over ``data_dir`` on 127.0.0.1:``port`` (as ``labjoint serve``)."""
    import uvicorn

    from labjoint.api import ApiSettings, create_app

    app = create_app(ApiSettings(data_dir=Path(data_dir), control_tokens=["bench-control-token"]))
    uvicorn.run(app, host="127.0.0.1", port=port, log_level="warning", access_log=False)


async def _get(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, path: str) -> bytes:
    writer.write(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nAccept: application/json\r\n\r\n"
                 .encode())
    head = await reader.readuntil(b"\r\n\r\n")
    status = int(head.split(b" ", 2)[1])
    length = next(int(line.split(b":", 1)[1]) for line in head.split(b"\r\n")
                  if line.lower().startswith(b"content-length:"))
    body = await reader.readexactly(length)
    if status != 200:
        raise RuntimeError(f"GET {path}: HTTP {status} {body[:200]!r}")
    return body


async def client(port: int, names: list[str], n_warm: int, n: int, seed: int,
                 out: list[float]) -> None:
    rng = random.Random(seed)
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        for i in range(n_warm + n):
            name = rng.choice(names)
            t0 = time.perf_counter()
            body = await _get(reader, writer, f"/api/v1/runs/{name}")
            dt = time.perf_counter() - t0
            if i >= n_warm:
                out.append(dt)
            if i == 0:
                assert json.loads(body)["name"] == name
    finally:
        writer.close()


async def load(port: int, names: list[str], clients: int, n: int) -> tuple[list[float], float]:
    lat: list[float] = []
    t0 = time.perf_counter()
    await asyncio.gather(*(client(port, names, 20, n, s, lat) for s in range(clients)))
    return lat, time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--clients", type=int, default=20)
    ap.add_argument("--requests", type=int, default=300, help="per client, after warm-up")
    ap.add_argument("--serve", nargs=2, metavar=("DATA_DIR", "PORT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.serve:
        serve(args.serve[0], int(args.serve[1]))
        return 0
    sys.path.insert(0, str(HERE.parent))
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp)
        t0 = time.perf_counter()
        names = make_catalog(data, args.runs)
        print(f"catalog: {len(names)} runs written in {time.perf_counter() - t0:.1f} s")
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        proc = subprocess.Popen([sys.executable, __file__, "--serve", str(data), str(port)])
        try:
            deadline = time.monotonic() + 30
            while True:
                try:
                    socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                    break
                except OSError:
                    if time.monotonic() > deadline or proc.poll() is not None:
                        raise RuntimeError("the API server did not start")
                    time.sleep(0.1)
            cpu0 = _cpu_seconds(proc.pid)
            lat, wall = asyncio.run(load(port, names, args.clients, args.requests))
            cpu = _cpu_seconds(proc.pid) - cpu0
        finally:
            proc.terminate()
            proc.wait(10)
    lat.sort()
    q = {p: lat[min(len(lat) - 1, int(p / 100 * len(lat)))] for p in (50, 90, 99)}
    print(f"GET /api/v1/runs/{{name}}, {args.runs} runs catalogued, {args.clients} clients, "
          f"{len(lat)} requests: {len(lat) / wall:.0f} req/s")
    print(f"latency ms: p50 {q[50] * 1e3:.1f}  p90 {q[90] * 1e3:.1f}  p99 {q[99] * 1e3:.1f}  "
          f"max {lat[-1] * 1e3:.1f}")
    n_all = args.clients * (args.requests + 20)
    print(f"server CPU per request: {cpu / n_all * 1e3:.2f} ms (one process: at most "
          f"{n_all / cpu:.0f} req/s; {args.clients} clients queue behind it, so an idle "
          f"machine would give a mean latency near {args.clients * cpu / n_all * 1e3:.0f} ms)")
    print(f"machine load during the run (1-min loadavg, {os.cpu_count()} CPUs): "
          f"{os.getloadavg()[0]:.1f}")
    ratio = q[99] / TARGET_P99_S
    print(f"p99 / target (50 ms): {ratio:.2f} -> {'OK' if ratio <= 1 else 'OVER TARGET'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
