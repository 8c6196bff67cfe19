"""Read ahead: iterate a block source in a background thread, a bounded number of blocks ahead."""

from __future__ import annotations

import queue
import threading
from typing import Iterable, Iterator, TypeVar

T = TypeVar("T")
_DONE = object()


def prefetch(blocks: Iterable[T], depth: int = 1) -> Iterator[T]:
    """The items of ``blocks``, produced by a background thread at most ``depth`` ahead.

    Reading the next block (file I/O, calibration) overlaps the processing of this one;
    memory grows by ``depth`` blocks at most. An exception raised by the source is
    raised here, at the item where it happened; closing this iterator early stops
    the reader.

    >>> list(prefetch(iter(range(5))))
    [0, 1, 2, 3, 4]
    """
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
