"""A VISA session's life cycle for the instrument drivers: open (every failure becomes
"not reachable: why"), device clear, and probing whether a query is supported.

Why each step exists (issue 18, checked against three AFG1022/AFG1000 drivers):

- pyvisa-py raises a plain ``ValueError`` from ``open_resource`` when libusb is missing
  or no device answers, NI-VISA a ``VisaIOError``, a missing library ``OSError``: the
  caller gets one :class:`~labjoint.errors.HardwareError` saying "not reachable" and why;
- a USB-TMC link can hold a half-read answer after a timeout; a device clear
  (``viClear``, pyvisa's ``Resource.clear()``) empties the instrument's input and output
  queues. pyvisa-sim has no ``viClear`` (``NotImplementedError``): skipped there;
- an unsupported query gets no answer (the instrument queues -113 "Undefined header"),
  so a probe waits a short timeout, clears the device, and says "not supported".
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pyvisa
import pyvisa.constants
import pyvisa.errors

from labjoint.errors import ConfigError, HardwareError

#: What a VISA exchange raises when the link or the session fails (pyvisa-py: ValueError).
VISA_FAILURES = (pyvisa.errors.VisaIOError, pyvisa.errors.InvalidSession, OSError, ValueError)

log = logging.getLogger(__name__)

#: How long a probe waits for an answer (ms): a USB instrument answers in a few ms.
PROBE_TIMEOUT_MS = 300


def open_session(resource: str, lib: str, timeout_ms: int) -> Any:
    """Open ``resource`` with the VISA library ``lib`` ('' the default); any failure of
    the library, the backend or the device raises HardwareError "<resource> not reachable"."""
    where = f"VISA library {lib or '(default)'!r}"
    try:
        rm = pyvisa.ResourceManager(lib)
    except Exception as exc:  # ValueError/OSError: no VISA implementation, library won't load
        raise HardwareError(f"{resource} not reachable: cannot load {where}: "
                            f"{type(exc).__name__}: {exc}") from exc
    try:
        res = rm.open_resource(resource, read_termination="\n", write_termination="\n",
                               timeout=timeout_ms)
    except Exception as exc:  # VisaIOError, pyvisa-py's ValueError (no libusb/device), OSError
        raise HardwareError(f"{resource} not reachable: cannot open {resource} with {where}: "
                            f"{type(exc).__name__}: {exc}") from exc
    if not getattr(res, "session", None):  # VI_NULL: pyvisa-sim's answer for an unknown resource
        raise HardwareError(f"{resource} not reachable: cannot open {resource} with {where}: "
                            "resource not found")
    return res


def device_clear(res: Any, resource: str) -> bool:
    """Send a device clear; True if sent, False (logged) if the backend has none or it failed."""
    try:
        res.clear()
        return True
    except NotImplementedError:  # a backend without viClear (plain pyvisa-sim; the twin has one)
        return False
    except Exception as exc:  # a dead link: the caller's next exchange will say so
        log.warning("%s: device clear failed: %s", resource, exc)
        return False


def probe_query(res: Any, query: str, resource: str, timeout_ms: int) -> str | None:
    """The answer to ``query``, or None when the instrument does not answer within a
    short timeout (then the device is cleared). Other VISA failures propagate."""
    old = res.timeout
    res.timeout = min(int(timeout_ms), PROBE_TIMEOUT_MS)
    try:
        return res.query(query).strip()
    except pyvisa.errors.VisaIOError as exc:
        if exc.error_code != pyvisa.constants.StatusCode.error_timeout:
            raise
        device_clear(res, resource)
        return None
    finally:
        res.timeout = old


#: The repository's configs folder, the same folder as ``labjoint.config.CONFIG_DIR``
#: (the hardware layer sits below config, so it cannot import it).
CONFIG_DIR = Path(__file__).resolve().parents[2] / "configs"


def resolve_visa_library(visa_library: str, config_dir: str | Path | None = None) -> str:
    """Turn a config's ``visa_library`` into what :class:`pyvisa.ResourceManager` takes.

    ``''`` is the default backend, ``'@sim'`` pyvisa-sim's bundled instruments, and
    ``'file.yaml@sim'`` a definition file, relative paths taken from the configs folder.

    >>> resolve_visa_library('')
    ''
    >>> resolve_visa_library('afg1022-sim.yaml@sim').endswith('configs/afg1022-sim.yaml@sim')
    True
    """
    lib = (visa_library or "").strip()
    if not lib.endswith("@sim") or lib == "@sim":
        return lib
    path = Path(lib[: -len("@sim")])
    if not path.is_absolute():
        path = Path(config_dir or CONFIG_DIR) / path
    if not path.is_file():
        raise ConfigError(f"pyvisa-sim instrument definition not found: {path}",
                          field="generator.visa_library")
    return f"{path}@sim"
