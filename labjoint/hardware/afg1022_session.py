"""Session steps of the AFG1022 driver: the load probe, reopening a stale session,
``*OPC?`` and draining the error queue (the driver class mixes these in).

Why each exists is in docs/bench-bringup.md (issue 18): the load is reported not
controllable over VISA by a driver written against the AFG1022 (asvela/tektronix-func-gen),
a dead USB link leaves a stale session, and back-to-back USB writes can be dropped.
"""

from __future__ import annotations

import logging

from labjoint.errors import HardwareError
from labjoint.hardware.visa_session import probe_query

log = logging.getLogger("labjoint.hardware.afg1022")


#: Probe answers per (VISA library, config dir, resource, channel, *IDN?) in this process:
#: an instrument and firmware answer the same way every time; reconnects skip the wait.
_LOAD_PROBES: dict[tuple, bool] = {}


class SessionSteps:
    """Mixed into :class:`~labjoint.hardware.afg1022.AFG1022` (uses its ``_query``,
    ``release`` and ``connect``)."""

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
