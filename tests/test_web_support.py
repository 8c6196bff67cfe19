"""Shared by the dashboard tests (no tests here): the service on a free loopback port
with the acquisition daemon on the simulated rig, seeded through real plans, and a
headless Chromium (Debian's /usr/bin/chromium, never downloaded) driven by Playwright."""

from __future__ import annotations

import contextlib
import os
import socket
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator
from urllib.parse import urlsplit

import httpx
import pytest

from labjoint.api.server import Service, build
from labjoint.identify.friction import identify_friction
from labjoint.identify.identified import save_identified
from labjoint.storage import read_run
from test_api_helpers import CONTROL, SHORT, sim_config_file, wait_for
import patience
from patience import http_client

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
ARTIFACTS = Path(__file__).resolve().parent.parent / "test-artifacts" / "web"
AUTH = {"Authorization": f"Bearer {CONTROL}"}
FINISHED = ("done", "failed", "cancelled", "aborted")
#: Sample rate of the seeded runs: >= 60 samples per cycle at 400 Hz for smooth loops.
SAMPLE_RATE_HZ = 25000.0
#: The amplitude sweep every browser test sees (Vpp at 400 Hz, 5 N m).
SWEEP_VPP = [2.0, 6.0, 12.0, 20.0]


@dataclass
class Site:
    """A running service: its base URL, an API client holding the control token, the
    service object and the runs seeded into it."""

    url: str
    http: httpx.Client
    svc: Service
    data_dir: Path
    sweep: list[str] = field(default_factory=list)


def run_plan(http: httpx.Client, plan: str, timeout: float = 120.0, **parameters: Any) -> dict:
    """Submit a plan and wait for it to finish; the final job."""
    r = http.post("/plans", json={"plan": plan, "parameters": parameters})
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    return wait_for(lambda: http.get(f"/plans/{jid}").json(), lambda j: j["status"] in FINISHED,
                    timeout=timeout)


def _config(tmp: Path) -> Path:
    cfg = sim_config_file(tmp, api=f'control_tokens = ["{CONTROL}"]\n')
    text = cfg.read_text()
    assert "sample_rate_hz = 10000.0" in text
    cfg.write_text(text.replace("sample_rate_hz = 10000.0", f"sample_rate_hz = {SAMPLE_RATE_HZ}"))
    return cfg


@contextlib.contextmanager
def site(tmp: Path) -> Iterator[Site]:
    """``labjoint serve``'s service (the API mounts the dashboard itself), seeded with an amplitude sweep and a
    friction test whose coefficient (seed 002 Eq. 10) is stored for the stick-slip method."""
    data = tmp / "data"
    svc = build(_config(tmp), data_dir=data, port=0, log_level="warning", env={})
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    svc.start_in_thread(sock)
    try:
        wait_for(lambda: svc.server.started, bool, timeout=10)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}"
        with http_client(url + "/api/v1", headers=AUTH) as http:
            sweep = run_plan(http, "amplitude_sweep", amplitudes_vpp=SWEEP_VPP, frequency_hz=400,
                             torque_nm=5, **SHORT)
            assert sweep["status"] == "done", sweep
            fric = run_plan(http, "friction_test", **SHORT)
            assert fric["status"] == "done", fric
            mu = identify_friction(read_run(data / f"{fric['runs'][0]}.h5"))
            save_identified(data, mu)
            yield Site(url, http, svc, data, sweep["runs"])
    finally:
        svc.stop()
        sock.close()


@contextlib.contextmanager
def chromium() -> Iterator[Any]:
    """Headless Debian Chromium through Playwright (skips when it is not installed,
    fails instead under ``LABJOINT_REQUIRE_BROWSER=1``, as CI runs: .ci/run)."""
    if not CHROMIUM.exists():
        why = f"{CHROMIUM} is not installed (make browser: apt-get install chromium)"
        if os.environ.get("LABJOINT_REQUIRE_BROWSER") == "1":
            pytest.fail(f"the browser tests must run here: {why}", pytrace=False)
        pytest.skip(why)
    from playwright.sync_api import sync_playwright
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            yield browser
        finally:
            browser.close()


@dataclass
class Watched:
    """A page and everything that went wrong on it: console errors, uncaught
    exceptions, failed or refused requests, and requests that tried to leave loopback."""

    page: Any
    errors: list[str] = field(default_factory=list)
    offsite: list[str] = field(default_factory=list)

    def problems(self) -> list[str]:
        return self.errors + [f"off-site request: {u}" for u in self.offsite]


def open_page(browser: Any, base_url: str, token: str | None = None, width: int = 1400,
              height: int = 1000) -> Watched:
    """A fresh page (new context, ``width`` x ``height`` CSS px) on ``base_url`` that
    records errors and blocks any request to another host; ``token`` is entered in the
    page's token box."""
    ctx = browser.new_context(viewport={"width": width, "height": height})
    ctx.set_default_timeout(patience.ms(30_000))       # Playwright's 30 s, scaled when busy
    page = ctx.new_page()
    w = Watched(page)
    host = urlsplit(base_url).netloc

    def guard(route: Any) -> None:
        u = route.request.url
        if urlsplit(u).netloc != host and not u.startswith(("data:", "blob:")):
            w.offsite.append(u)
            route.abort()
        else:
            route.continue_()

    page.route("**/*", guard)
    page.on("console", lambda m: w.errors.append(f"console {m.type}: {m.text}")
            if m.type in ("error", "warning") else None)
    page.on("pageerror", lambda e: w.errors.append(f"page error: {e}"))
    page.on("requestfailed", lambda r: w.errors.append(f"request failed: {r.url} {r.failure}"))
    page.on("response", lambda r: w.errors.append(f"HTTP {r.status}: {r.url}")
            if r.status >= 400 else None)
    page.goto(base_url + "/#/runs")
    if token is not None:
        page.fill("#token", token)
        page.click("#token-form button")
        page.wait_for_selector("#token-state.set")
    return w


def screenshot(page: Any, name: str) -> Path:
    """Full-page PNG under test-artifacts/web/."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    p = ARTIFACTS / f"{name}.png"
    page.screenshot(path=str(p), full_page=True)
    return p


def wait_attr(page: Any, selector: str, attr: str, done: Any, timeout: float = 30.0) -> str:
    """Poll ``selector``'s ``attr`` until ``done(value)`` (the page's CSP forbids the
    string evaluation behind Playwright's wait_for_function); the value."""
    def get() -> str | None:
        loc = page.locator(selector)
        return loc.first.get_attribute(attr) if loc.count() else None
    return wait_for(get, lambda v: v is not None and done(v), timeout=timeout, poll=0.1)
