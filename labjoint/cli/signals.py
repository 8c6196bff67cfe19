"""SIGTERM handled like Ctrl-C while a command writes run files, so every run it opened is
closed with a final status ("aborted") instead of staying "running" (kill -9 cannot be
handled: `labjoint recover` closes what it leaves)."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Within the block (main thread only), SIGTERM raises KeyboardInterrupt.

    An exception raised from a signal handler is lost when the signal lands in a weakref
    callback or a ``__del__`` (Python prints "Exception ignored in ..." and goes on); the
    signal is remembered, and a block that then ends normally raises KeyboardInterrupt at
    its end, so the command still exits as interrupted (130)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[str] = []

    def _raise(signum: int, frame: Any) -> None:
        received.append(signal.Signals(signum).name)
        raise KeyboardInterrupt(f"signal {received[-1]}")

    previous = signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
    if received:                          # the in-block raise was swallowed
        raise KeyboardInterrupt(f"signal {received[0]}")
