"""Session steps of the AFG1022 driver: every exchange with the instrument (a write, a query,
a waveform block) and what a failed one does, the load probe, reopening a stale session,
``*OPC?`` and draining the error queue (the driver class mixes these in).

Why each exists is in docs/bench-bringup.md (issue 18): the load is reported not
controllable over VISA by a driver written against the AFG1022 (asvela/tektronix-func-gen),
a dead USB link leaves a stale session, and back-to-back USB writes can be dropped.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pyvisa.constants
import pyvisa.errors

from labjoint.errors import HardwareError, InstrumentTimeout
from labjoint.hardware.visa_session import VISA_FAILURES, device_clear, probe_query

log = logging.getLogger("labjoint.hardware.afg1022")


#: Probe answers per (VISA library, config dir, resource, channel, *IDN?) in this process:
#: an instrument and firmware answer the same way every time; reconnects skip the wait.
_LOAD_PROBES: dict[tuple, bool] = {}

CHANNELS = (1, 2)


class SessionSteps:
    """Mixed into :class:`~labjoint.hardware.afg1022.AFG1022` (uses its ``_res``,
    ``_stale``, ``_known``, ``release`` and ``connect``)."""

    @contextmanager
    def _exchange(self, what: str) -> Iterator[Any]:
        """The open session for one exchange (``what``: the command, for messages), reopened
        first if stale. A VISA failure becomes a labjoint error (:meth:`_failure`); an
        exchange cut short otherwise (Ctrl-C between a query's write and its read) leaves
        the session stale: what reached the instrument is unknown and an answer may wait in
        its output queue, which the next exchange would read as its own; reopening device-
        clears it."""
        if self._stale:
            self._reopen()
        if self._res is None:
            raise HardwareError(f"{self.resource}: not connected (sending {what!r})")
        try:
            yield self._res
        except VISA_FAILURES as exc:
            raise self._failure(what, exc) from exc
        except BaseException:
            self._stale = True
            raise

    def _write(self, cmd: str) -> None:
        with self._exchange(cmd) as res:
            res.write(cmd)

    def _query(self, cmd: str) -> str:
        with self._exchange(cmd) as res:
            return res.query(cmd).strip()

    def _query_float(self, cmd: str) -> float:
        text = self._query(cmd)
        try:
            value = float(text)
        except ValueError:
            raise HardwareError(f"{self.resource}: {cmd!r} answered {text!r}, not a number") from None
        return value


    def _failure(self, cmd: str, exc: Exception) -> HardwareError:
        """Map a VISA failure to a labjoint error, after trying to leave the output OFF."""
        timed_out = (isinstance(exc, pyvisa.errors.VisaIOError)
                     and exc.error_code == pyvisa.constants.StatusCode.error_timeout)
        if timed_out and self._res is not None:  # drop a half-read answer before OFF
            device_clear(self._res, self.resource)
        off = self._safe_off()
        self._stale, self._known = True, None
        state = "output switched OFF (both channels)" if off else "could not switch the output OFF"
        if timed_out:
            return InstrumentTimeout(f"{self.resource}: no answer to {cmd!r} within "
                                     f"{self.timeout_ms} ms ({state})")
        return HardwareError(f"{self.resource}: {cmd!r} failed: {exc} ({state})")

    def _safe_off(self) -> bool:
        """Try ``OUTPut<n>:STATe OFF`` on both channels; True if sent, False (logged) if
        the link is dead."""
        res = self._res
        if res is None:
            return False
        try:
            for ch in CHANNELS:
                res.write(f"OUTPut{ch}:STATe OFF")
            return True
        except Exception as exc:  # the safe state must never raise
            log.error("%s: could not switch the output OFF: %s", self.resource, exc)
            return False

    def _probe_load(self, idn: str) -> bool:
        """Does ``OUTPut<n>:IMPedance?`` answer? Asked once per instrument and process,
        with a short timeout; unanswered, the configured load stands and is never sent."""
        key = (self.visa_library, str(self.config_dir), self.resource, self.channel, idn)
        if key not in _LOAD_PROBES:
            answer = probe_query(self._res, f"OUTPut{self.channel}:IMPedance?", self.resource,
                                 self.timeout_ms)
            self._drain_errors()  # what an unsupported header left in the error queue
            _LOAD_PROBES[key] = answer is not None
            if not _LOAD_PROBES[key]:
                # said once per instrument and process; the simulated twin (which models
                # a firmware without the header) says it at info level, not as a warning
                level = logging.INFO if str(self.visa_library).endswith("@sim") else logging.WARNING
                log.log(level, "%s: OUTPut%d:IMPedance is not supported; the load is the "
                        "configured %s (set the same on the front panel), never sent",
                        self.resource, self.channel, self.load)
        return _LOAD_PROBES[key]

    def _reopen(self) -> None:
        """A fresh VISA session after a hardware error (a dead USB link leaves a stale one)."""
        log.warning("%s: reopening the VISA session after a hardware error", self.resource)
        self._stale = False
        self.release()
        try:
            self.connect()
        except BaseException:
            self._stale = True
            raise

    def _opc(self, during: str) -> None:
        """``*OPC?`` after a group of writes: answers 1 once all of them were executed."""
        text = self._query("*OPC?")
        if text != "1":
            raise HardwareError(f"{self.resource}: *OPC? answered {text!r} during {during}")

    def _drain_errors(self) -> list[str]:
        """Read ``SYSTem:ERRor?`` until it says no error; the messages read."""
        errors = []
        for _ in range(32):
            text = self._query("SYSTem:ERRor?")
            if text.split(",", 1)[0].strip() in ("0", "+0"):
                break
            errors.append(text)
        return errors
