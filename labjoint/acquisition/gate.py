"""Where a running plan waits for the operator: a torque change or a pause.

The engine asks (:meth:`TorqueGate.ask`, blocking in the engine's thread); the CLI or
the REST service sees :attr:`TorqueGate.pending` and answers from another thread with
:meth:`TorqueGate.confirm` (continue, optionally with the torque actually applied) or
:meth:`TorqueGate.cancel` (the plan ends with status 'aborted').

>>> gate = TorqueGate()
>>> gate.pending is None
True
"""

from __future__ import annotations

import math
import threading
from typing import Any

from labjoint.errors import InputError, LabjointError


class GateCancelled(LabjointError):
    """The operator cancelled instead of continuing."""


class TorqueGate:
    """A thread-safe, one-request-at-a-time handshake between engine and operator."""

    def __init__(self, poll_s: float = 0.05) -> None:
        self.poll_s = poll_s
        self._cond = threading.Condition()
        self._pending: dict[str, Any] | None = None
        self._answer: dict[str, Any] | None = None
        self._cancelled: str | None = None

    @property
    def pending(self) -> dict[str, Any] | None:
        """What the engine waits for, e.g. ``{'kind': 'torque', 'torque_nm': 5.0}``, or None."""
        with self._cond:
            return None if self._pending is None else dict(self._pending)

    def confirm(self, torque_nm: float | None = None) -> None:
        """Continue the plan; ``torque_nm`` is the torque actually applied (default: the
        one requested)."""
        with self._cond:
            if self._pending is None:
                raise InputError("the engine is not waiting for the operator", field="torque_nm")
            answer: dict[str, Any] = {}
            if torque_nm is not None:
                t = float(torque_nm)
                if not (math.isfinite(t) and t > 0):
                    raise InputError(f"torque must be positive, got {torque_nm!r}", field="torque_nm")
                answer["torque_nm"] = t
            elif "torque_nm" in self._pending:
                answer["torque_nm"] = self._pending["torque_nm"]
            self._answer = answer
            self._pending = None
            self._cond.notify_all()

    def resume(self) -> None:
        """Continue after a pause (same as :meth:`confirm` without a torque)."""
        self.confirm()

    def cancel(self, reason: str = "cancelled by the operator") -> None:
        """End the waiting plan (status 'aborted')."""
        with self._cond:
            if self._pending is None:
                raise InputError("the engine is not waiting for the operator", field="pending")
            self._cancelled = reason
            self._pending = None
            self._cond.notify_all()

    def ask(self, kind: str, abort: threading.Event | None = None, **info: Any) -> dict[str, Any]:
        """Engine side: publish a request and block until confirmed, cancelled or aborted.

        Returns the operator's answer; raises :class:`GateCancelled` if cancelled. If
        ``abort`` is set meanwhile, returns ``{'aborted': True}`` (the engine checks).
        """
        with self._cond:
            self._pending = {"kind": kind, **info}
            self._answer = None
            self._cancelled = None
            try:
                while self._answer is None and self._cancelled is None:
                    if abort is not None and abort.is_set():
                        return {"aborted": True}
                    self._cond.wait(self.poll_s)
                if self._cancelled is not None:
                    raise GateCancelled(self._cancelled)
                return dict(self._answer)
            finally:
                self._pending = None

    def wake(self) -> None:
        """Make a waiting :meth:`ask` re-check its abort event now."""
        with self._cond:
            self._cond.notify_all()
