"""Operating-system signals as an emergency stop of a running engine."""

from __future__ import annotations

import contextlib
import signal
from typing import Any, Iterator, Protocol, Sequence


class Stoppable(Protocol):
    def emergency_stop(self, reason: str = ...) -> None: ...


@contextlib.contextmanager
def stop_on_signals(engine: Stoppable, signals: Sequence[int] = (signal.SIGTERM,)) -> Iterator[None]:
    """Within the block, the given signals trigger ``engine.emergency_stop`` (main thread
    only; Ctrl-C already ends a plan through KeyboardInterrupt)."""
    previous = {}

    def handler(signum: int, frame: Any) -> None:
        engine.emergency_stop(f"signal {signal.Signals(signum).name}")

    for s in signals:
        previous[s] = signal.signal(s, handler)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
