"""Operating-system signals as an emergency stop of a running engine.

The handler only raises the engine's flag (no exception): an exception raised from a
signal handler is lost when the signal lands in a weakref callback or a ``__del__``
("Exception ignored in ..."), and the plan then runs on as if never signalled. The flag
is read at the engine's next block, which closes the open run as 'aborted'.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from dataclasses import dataclass
from typing import Any, Iterator, Protocol, Sequence


class Stoppable(Protocol):
    def emergency_stop(self, reason: str = ...) -> None: ...


@dataclass
class Received:
    """Which signal stopped the engine within the block (None: none did)."""

    name: str | None = None


@contextlib.contextmanager
def stop_on_signals(engine: Stoppable,
                    signals: Sequence[int] = (signal.SIGTERM,)) -> Iterator[Received]:
    """Within the block, the given signals trigger ``engine.emergency_stop`` and are
    recorded in the yielded :class:`Received` (main thread only; elsewhere signals cannot
    be handled and the block runs without)."""
    received = Received()
    if threading.current_thread() is not threading.main_thread():
        yield received
        return
    previous = {}

    def handler(signum: int, frame: Any) -> None:
        received.name = signal.Signals(signum).name
        engine.emergency_stop(f"signal {received.name}")

    for s in signals:
        previous[s] = signal.signal(s, handler)
    try:
        yield received
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
