"""How long a test waits for work done in another thread, process or browser.

These are deadlines against a hang, never checks of speed: on a 2-core machine shared
with other work (load 7-10) a request that takes 4 s alone can take a minute, so every
wait in the suite goes through :func:`s` (or :data:`HTTP_TIMEOUT_S` for HTTP clients),
scaled by ``LABJOINT_TEST_TIMEOUT_SCALE`` (default 10). Speed is measured in
benchmarks/, as ratios, not here.
"""

from __future__ import annotations

import os
from typing import Any

import httpx

#: multiplies every wait written in the tests (their values are what a quiet machine needs)
SCALE = float(os.environ.get("LABJOINT_TEST_TIMEOUT_SCALE", "10"))
#: per-request timeout of the tests' HTTP clients on in-process servers (httpx's default, 5 s,
#: failed test_web_mount under load with httpx.ReadTimeout)
HTTP_TIMEOUT_S = 60.0 * SCALE


def s(seconds: float) -> float:
    """A wait of ``seconds`` on a quiet machine, scaled for a busy one."""
    return float(seconds) * SCALE


def ms(milliseconds: float) -> float:
    """:func:`s` in milliseconds (Playwright's unit)."""
    return float(milliseconds) * SCALE


def http_client(base_url: str = "", **kwargs: Any) -> httpx.Client:
    """An httpx client with the tests' generous timeout (``timeout=`` overrides it)."""
    kwargs.setdefault("timeout", HTTP_TIMEOUT_S)
    return httpx.Client(base_url=base_url, **kwargs)
