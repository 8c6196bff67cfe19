"""Read ahead: iterate a block source in a background thread, a bounded number of blocks ahead.

Also the switch that keeps a record's pipeline in one thread: :func:`helper_pool` gives a
one-thread pool, or an :class:`InlineExecutor` that runs each job at once in the caller's
thread (for batches that already keep every core busy with one record each, where the
helper threads only add work).
"""

from __future__ import annotations

import queue
import threading
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from typing import Any, Callable, Iterable, Iterator, TypeVar

T = TypeVar("T")
_DONE = object()


class InlineExecutor(Executor):
    """An executor that runs each job in the calling thread when it is submitted.

    >>> with InlineExecutor() as ex:
    ...     ex.submit(divmod, 7, 2).result()
    (3, 1)
    """

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        fut: Future = Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 - handed to whoever takes the result
            fut.set_exception(exc)
        return fut


def helper_pool(threads: bool, name: str) -> Executor:
    """A one-thread pool named ``name`` when ``threads``, else an :class:`InlineExecutor`."""
    return ThreadPoolExecutor(1, thread_name_prefix=name) if threads else InlineExecutor()


def prefetch(blocks: Iterable[T], depth: int = 1, threads: bool = True) -> Iterator[T]:
    """The items of ``blocks``, produced by a background thread at most ``depth`` ahead.

    Reading the next block (file I/O, calibration) overlaps the processing of this one;
    memory grows by ``depth`` blocks at most. An exception raised by the source is
    raised here, at the item where it happened; closing this iterator early stops
    the reader.

    With ``threads=False`` the items are read in the caller's thread, when asked for.

    >>> list(prefetch(iter(range(5))))
    [0, 1, 2, 3, 4]
    """
    if not threads:
        return iter(blocks)
    return _read_ahead(blocks, depth)


def _read_ahead(blocks: Iterable[T], depth: int) -> Iterator[T]:
    slots: queue.Queue = queue.Queue(maxsize=max(1, int(depth)))
    stop = threading.Event()

    def put(item: object) -> bool:
        while not stop.is_set():
            try:
                slots.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def reader() -> None:
        try:
            for item in blocks:
                if not put((item, None)):
                    return
        except BaseException as exc:  # noqa: BLE001 - handed to the consumer
            put((_DONE, exc))
            return
        put((_DONE, None))

    thread = threading.Thread(target=reader, name="labjoint-prefetch", daemon=True)
    thread.start()
    try:
        while True:
            item, exc = slots.get()
            if item is _DONE:
                if exc is not None:
                    raise exc
                return
            yield item
    finally:
        stop.set()
        thread.join()
