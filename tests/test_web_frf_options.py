"""The FRFs view's estimator options in a real headless Chromium: a force-driven burst
record of the 2-DOF chain (tests/spectra_runs.py, linear, closed-form modes) computed from
the page with burst=driven and burst=block; the stored sets say which estimator made them
(the set's own metadata, read back over REST), the page says it too, the modes of both
match the closed form; a method the record cannot take (periodic on a random burst) is
refused on the page naming the drive, and no set is stored under that name."""

from __future__ import annotations

import httpx
import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.storage import Catalog
from spectra_runs import closed_modes, random_force
from test_api_helpers import CONTROL, live_server
from test_web_support import AUTH, chromium, open_page

pytestmark = pytest.mark.browser


def _compute(page, name: str, method: str, burst: str) -> None:
    page.select_option("#frf-method", method)
    page.select_option("#frf-burst", burst)
    page.fill("#frf-name", name)
    page.click("#frf-go")


def _modes(page) -> list[float]:
    rows = page.locator("#frf-modes tbody tr")
    return [float(rows.nth(i).locator("td").nth(3).text_content()) for i in range(rows.count())]


def test_burst_estimator_is_chosen_on_the_page_and_stored(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    random_force(data / "burst.h5", 2.0, seed=5, rest=0.4)
    Catalog(data / "catalog.sqlite").rebuild(data)
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    want = [m[0] for m in closed_modes(False)]
    with live_server(app) as url, chromium() as browser:
        w = open_page(browser, url, token=CONTROL)
        page = w.page
        page.goto(f"{url}/#/frf")
        page.wait_for_selector("#frf-runs input[value='burst']", timeout=60_000)
        page.locator("#frf-runs input[value='burst']").check()

        _compute(page, "drv", "auto", "driven")
        page.wait_for_selector("#frf-modes tbody tr", timeout=180_000)
        about = page.text_content("#frf-method-about")
        assert "burst=driven" in about and "local rational method" in about
        assert _modes(page) == pytest.approx(want, rel=2e-3)

        _compute(page, "blk", "auto", "block")
        page.wait_for_selector("#frf-method-about:has-text('burst=block')", timeout=180_000)
        page.wait_for_selector("#frf-modes tbody tr", timeout=180_000)
        assert _modes(page) == pytest.approx(want, rel=2e-3)

        _compute(page, "per", "periodic", "block")
        page.wait_for_selector("#frf-msg.error", timeout=120_000)
        msg = page.text_content("#frf-msg")
        assert "drive" in msg and "not periodic" in msg, msg
        assert w.problems() == []

    with live_server(app) as url:
        sets = {n: httpx.get(f"{url}/api/v1/spectra/frf/{n}", headers=AUTH, timeout=30)
                for n in ("drv", "blk", "per")}
    assert "burst=driven" in sets["drv"].json()["metadata"]["method"]
    assert "burst=block" in sets["blk"].json()["metadata"]["method"]
    assert sets["per"].status_code == 404

