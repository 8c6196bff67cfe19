"""REST latency: GET /api/v1/runs/{name} with 1,000 runs catalogued, 20 concurrent clients.

The service runs as ``labjoint serve`` does (one uvicorn process, reads open, bound to
127.0.0.1) in a subprocess; the catalog holds 1,000 runs (copies of one real run file
written by the storage layer, each catalogued under its own name and conditions). 20
clients on loopback, each on its own keep-alive connection, ask for random runs'
summaries back to back; each request's latency is measured from sending the request to
the last body byte. The clients speak HTTP/1.1 over raw asyncio streams, so the figures
are the server's, not an HTTP library's (the clients' event loop is uvloop when installed,
as the server's is: the clients share the machine's cores with the server). The server is
uvicorn with its defaults, which pick httptools and uvloop (project dependencies; the
output names them). Target: p99 <= 10 ms (issue 31; it was 50 ms).
Reference: the same clients' p99 of GET /api/v1/health measured in the same rounds (no
catalog read, but a sync route: each request hops to the thread pool, where the run
summary is async and answered directly), so the ratio places the catalog read against
the service's plainest route.

Usage: ``.venv/bin/python benchmarks/bench_api.py [--runs 1000] [--clients 20]
[--requests 300] [--repeats 3] [--smoke]`` (requests per client, after 20 warm-up requests
each; the p99 is the median over the repeats' p99).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_P99_S = 0.010
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from benchmarks.harness import Bench, parser  # noqa: E402


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
    with cat.sql.transaction() as con:
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


async def client(port: int, paths: list[str], n_warm: int, n: int, seed: int,
                 out: list[float]) -> None:
    rng = random.Random(seed)
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        for i in range(n_warm + n):
            path = rng.choice(paths)
            t0 = time.perf_counter()
            body = await _get(reader, writer, path)
            dt = time.perf_counter() - t0
            if i >= n_warm:
                out.append(dt)
            if i == 0 and path.startswith("/api/v1/runs/"):
                assert json.loads(body)["name"] == path.rsplit("/", 1)[1]
    finally:
        writer.close()


async def load(port: int, paths: list[str], clients: int, n: int,
               n_warm: int = 20) -> tuple[list[float], float]:
    lat: list[float] = []
    t0 = time.perf_counter()
    await asyncio.gather(*(client(port, paths, n_warm, n, s, lat) for s in range(clients)))
    return lat, time.perf_counter() - t0


def quantiles(lat: list[float]) -> dict[int, float]:
    lat = sorted(lat)
    return {p: lat[min(len(lat) - 1, int(p / 100 * len(lat)))] for p in (50, 90, 99)}


def _run(coro):
    """``coro`` on uvloop when installed (the server's loop too), else asyncio's."""
    try:
        import uvloop
    except ImportError:
        return asyncio.run(coro)
    return uvloop.run(coro)


def _server_stack() -> str:
    """What uvicorn's "auto" picks for the HTTP parser and the event loop."""
    import importlib.util as u
    http = "httptools" if u.find_spec("httptools") else "h11 (pure Python)"
    loop = "uvloop" if u.find_spec("uvloop") else "asyncio"
    return f"uvicorn, {http} parser, {loop} loop, one process"


def main() -> int:
    ap = parser(__doc__)
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--clients", type=int, default=20)
    ap.add_argument("--requests", type=int, default=300, help="per client, after warm-up")
    ap.add_argument("--serve", nargs=2, metavar=("DATA_DIR", "PORT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.serve:
        serve(args.serve[0], int(args.serve[1]))
        return 0
    if args.smoke:
        args.runs, args.clients, args.requests = 20, 4, 10
    bench = Bench.from_args("api", args, repeats=3)
    bench.numba = "not used by these routes (the server is warmed by 20 requests per client)"
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
            deadline = time.monotonic() + 120
            while True:
                try:
                    socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                    break
                except OSError:
                    if time.monotonic() > deadline or proc.poll() is not None:
                        raise RuntimeError("the API server did not start")
                    time.sleep(0.1)
            runs = [f"/api/v1/runs/{n}" for n in names]
            p99s, p99_health, all_lat, cpu, n_all, wall = [], [], [], 0.0, 0, 0.0
            own0 = time.process_time()
            for _ in range(bench.repeats):      # alternate: the same load for both
                cpu0 = _cpu_seconds(proc.pid)
                lat, w = _run(load(port, runs, args.clients, args.requests))
                cpu += _cpu_seconds(proc.pid) - cpu0
                n_all += args.clients * (args.requests + 20)
                wall += w
                all_lat += lat
                p99s.append(quantiles(lat)[99])
                h, _ = _run(load(port, ["/api/v1/health"], args.clients, args.requests))
                p99_health.append(quantiles(h)[99])
            own = time.process_time() - own0      # the clients' CPU, both routes
        finally:
            proc.terminate()
            proc.wait(10)
    q = quantiles(all_lat)
    p99 = statistics.median(p99s)
    print(f"GET /api/v1/runs/{{name}}, {args.runs} runs catalogued, {args.clients} clients, "
          f"{len(all_lat)} requests in {bench.repeats} rounds: {len(all_lat) / wall:.0f} req/s")
    print(f"latency ms (all rounds): p50 {q[50] * 1e3:.1f}  p90 {q[90] * 1e3:.1f}  p99 "
          f"{q[99] * 1e3:.1f}  max {max(all_lat) * 1e3:.1f}; p99 per round "
          + ", ".join(f"{x * 1e3:.1f}" for x in p99s))
    print(f"server: {_server_stack()}; clients' CPU per request (both routes): "
          f"{own / (2 * n_all) * 1e3:.2f} ms")
    print(f"server CPU per request: {cpu / n_all * 1e3:.2f} ms (one process: at most "
          f"{n_all / cpu:.0f} req/s; {args.clients} clients queue behind it, so an idle "
          f"machine would give a mean latency near {args.clients * cpu / n_all * 1e3:.1f} ms)")
    bench.figure("p99 GET run summary / target", p99 / TARGET_P99_S,
                 f"the {TARGET_P99_S * 1e3:g} ms p99 goal", value=p99 * 1e3, unit="ms",
                 target="<= 1", p50_ms=q[50] * 1e3, p90_ms=q[90] * 1e3)
    bench.figure("p99 GET run summary / p99 GET health", p99 / statistics.median(p99_health),
                 "the p99 of GET /api/v1/health in the same rounds (no catalog read; a sync, "
                 "thread-pool route)",
                 value=statistics.median(p99_health) * 1e3, unit="ms (health p99)")
    bench.finish(runs=args.runs, clients=args.clients, requests_per_client=args.requests,
                 server_cpu_ms_per_request=cpu / n_all * 1e3, server=_server_stack(),
                 p50_ms=q[50] * 1e3, p99_all_rounds_ms=q[99] * 1e3)
    return 0


if __name__ == "__main__":
    sys.exit(main())
