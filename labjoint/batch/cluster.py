"""Reprocess tasks on Dask (``dask.distributed``): a LocalCluster, or a lab's scheduler.

:func:`dask_client` yields a connected client: ``"local"`` starts a LocalCluster sized to
the machine (one worker process per core, one thread each) and stops it afterwards; a
``tcp://HOST:PORT`` address connects to a running ``dask scheduler`` whose workers run
the project's environment and see the run files at the same paths (a shared filesystem).
:class:`DaskRunner` submits each task with ``retries=1``: a task that raises is run once
more, and a task whose worker dies is resubmitted by the scheduler once (the LocalCluster
is started with ``allowed_failures=1``; a lab's scheduler takes the same setting,
``distributed.scheduler.allowed-failures``), then reported. Tasks get run paths and
options; they return small dicts.
"""

from __future__ import annotations

import ctypes
import functools
import os
import sys
from contextlib import contextmanager
from typing import Any, Iterator

from labjoint.batch.tasks import Task, run_task
from labjoint.errors import InputError

#: times the scheduler reruns a task whose worker died before it reports KilledWorker
ALLOWED_FAILURES = 1
#: most single-run tasks sent to a worker as one Dask task
MAX_CHUNK = 16
#: Dask tasks per worker at least, when runs are chunked (so the load still balances)
CHUNKS_PER_WORKER = 8
#: seconds to wait for a scheduler before saying it cannot be reached
CONNECT_TIMEOUT_S = 5.0
#: glibc's mallopt parameters (malloc.h) and the limits a worker sets
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
MMAP_THRESHOLD_BYTES = 32 << 20
TRIM_THRESHOLD_BYTES = 64 << 20


@contextmanager
def dask_client(scheduler: str = "local", n_workers: int | None = None,
                dashboard: str | None = ":0",
                timeout_s: float = CONNECT_TIMEOUT_S) -> Iterator[Any]:
    """A Dask client on a new LocalCluster (``"local"``) or on the scheduler at
    ``scheduler``; closed (and the LocalCluster stopped) on exit."""
    from distributed import Client, LocalCluster

    if scheduler == "local":
        n = int(n_workers or os.cpu_count() or 1)
        if n < 1:
            raise InputError(f"must be >= 1, got {n_workers}", field="workers")
        kwargs: dict[str, Any] = {"allowed_failures": ALLOWED_FAILURES}
        if dashboard is None:     # its HTTP server (metrics) still listens: on any port,
            kwargs.update(dashboard=False, dashboard_address=":0")   # not on 8787
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                          dashboard_address=dashboard, scheduler_kwargs=kwargs) as cluster, \
                Client(cluster) as client:
            yield client
        return
    if not isinstance(scheduler, str) or "://" not in scheduler:
        raise InputError(f"must be 'local' or an address such as tcp://HOST:8786, got "
                         f"{scheduler!r}", field="scheduler")
    try:
        client = Client(scheduler, timeout=f"{timeout_s}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(f"cannot reach the Dask scheduler at {scheduler}: "
                         f"{type(exc).__name__}: {exc}", field="scheduler") from None
    with client:
        yield client


def dashboard_line(client: Any) -> str:
    """The line naming the Dask dashboard (bokeh, a dependency, serves its pages)."""
    link = getattr(client, "dashboard_link", None)
    if not link:
        return "Dask dashboard: none (the scheduler serves no dashboard)"
    return f"Dask dashboard: {link}"


class DaskRunner:
    """Runs reprocess tasks on a Dask client's workers, yielding them as they end.

    Single-run tasks are sent in chunks of ``chunk`` (default: up to ``MAX_CHUNK``, so
    that each worker still gets about ``CHUNKS_PER_WORKER`` of them): a run's analysis
    takes tens of milliseconds, and one Dask task per run would spend a good part of
    that in the scheduler and this client. ``fn(task) -> dict``, when given, is what
    each task runs, one per Dask task (default :func:`run_on_worker`)."""

    def __init__(self, client: Any, fn: Any = None, chunk: int | None = None) -> None:
        self.client = client
        self.fn = fn
        self.chunk = chunk

    @property
    def dashboard_link(self) -> str | None:
        return getattr(self.client, "dashboard_link", None)

    def _chunks(self, tasks: list[Task]) -> list[list[Task]]:
        from labjoint.batch.pipelines import get_pipeline

        size = self.chunk
        if self.fn is not None or get_pipeline(tasks[0].pipeline).grouped:
            size = 1
        elif size is None:
            workers = max(len(self.client.scheduler_info().get("workers", {})), 1)
            size = max(1, min(MAX_CHUNK, len(tasks) // (CHUNKS_PER_WORKER * workers)))
        return [tasks[a:a + size] for a in range(0, len(tasks), size)]

    def run(self, tasks: list[Task]) -> Iterator[tuple[Task, dict[str, Any] | BaseException]]:
        from distributed import as_completed

        if not tasks:
            return
        futs = {}
        for part in self._chunks(tasks):
            fn, arg = (self.fn, part[0]) if self.fn is not None else (run_chunk, part)
            f = self.client.submit(fn, arg, retries=1, pure=False,
                                   key=f"reprocess-{part[0].pipeline}-{part[0].key}"
                                       f"-{os.urandom(4).hex()}")
            futs[f.key] = (f, part)
        pending = set(futs)
        try:
            for f in as_completed([f for f, _ in futs.values()]):
                pending.discard(f.key)
                part = futs[f.key][1]
                try:
                    out = f.result()
                except Exception as exc:   # raised twice, or its worker died twice
                    for t in part:
                        yield t, exc
                    continue
                for t, res in zip(part, out if self.fn is None else [out]):
                    yield t, res
        finally:
            left = [futs[k][0] for k in pending]
            if left:
                self.client.cancel(left)


class DaskExecutor:
    """A Dask client as diagnose's candidate-refit executor (``submit``, ``share``)."""

    def __init__(self, client: Any) -> None:
        self.client = client

    def submit(self, fn: Any, *args: Any) -> Any:
        return self.client.submit(fn, *args, pure=False)

    def share(self, obj: Any) -> Any:
        """Send ``obj`` to the cluster once; the handle tasks receive it through."""
        (fut,) = self.client.scatter([obj], hash=False)
        return fut


@contextmanager
def worker_executor() -> Iterator[DaskExecutor]:
    """Inside a Dask task: an executor on the cluster the task runs on (the task's
    thread leaves the worker's pool while it waits, so its slot serves the refits)."""
    from distributed import worker_client

    with worker_client() as client:
        yield DaskExecutor(client)


@functools.cache
def tune_allocator() -> bool:
    """Let this process's allocator reuse freed blocks of up to 32 MB (glibc; once).

    A Dask nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536``, and a fixed
    trim threshold also freezes glibc's mmap threshold at 128 kB: every array of a
    record block is then mapped afresh and its pages faulted in again, which nearly
    doubled a run's analysis in a worker (62 -> 110 ms for a 10 s record). These are
    the limits glibc's own dynamic rule reaches (32 MB; trim at twice that), made fixed.
    False where there is no glibc ``mallopt``."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and \
        bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES))


def run_chunk(tasks: list[Task]) -> list[dict[str, Any]]:
    """:func:`run_on_worker` on each task of a chunk, in order."""
    return [run_on_worker(t) for t in tasks]


def run_on_worker(task: Task) -> dict[str, Any]:
    """:func:`~labjoint.batch.tasks.run_task` as a Dask task, one record per worker
    thread (no helper threads of its own); a diagnosis or ladder with ``spread`` sends
    its candidate refits to the cluster's workers."""
    tune_allocator()
    if not task.spread:
        return run_task(task, threads=False)
    with worker_executor() as ex:
        return run_task(task, ex, threads=False)
