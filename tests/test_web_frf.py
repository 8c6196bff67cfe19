"""The FRFs view in a real headless Chromium, at 1400 and 390 px: FRFs of a voltage-driven
2-DOF chain (tests/spectra_runs.py) computed from the page, magnitude/phase/coherence
drawn in m/s/V (never N), the modes table at the closed-form frequencies, and the
distortion report of a sine through a known polynomial; no page wider than the screen."""

from __future__ import annotations

import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.storage import Catalog
from spectra_runs import closed_modes, odd_multisine_cubic, random_voltage, sine_ratios, sine_voltage
from test_api_helpers import CONTROL, live_server
from test_web_support import chromium, open_page, screenshot, wait_attr

pytestmark = pytest.mark.browser


def _tick(page, box: str, name: str) -> None:
    page.locator(f"#{box} input[value='{name}']").check()


@pytest.mark.parametrize("width", [1400, 390])
def test_frf_view_plots_modes_and_distortion(tmp_path, width):
    data = tmp_path / "data"
    data.mkdir()
    random_voltage(data / "volt.h5", 0.3, seed=3)
    sine_voltage(data / "sine.h5")
    odd_multisine_cubic(data / "ms.h5")
    Catalog(data / "catalog.sqlite").rebuild(data)
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    with live_server(app) as url, chromium() as browser:
        w = open_page(browser, url, token=CONTROL)
        page = w.page
        page.set_viewport_size({"width": width, "height": 900})
        page.goto(f"{url}/#/frf")
        page.wait_for_selector("#frf-runs input[value='volt']", timeout=60_000)
        _tick(page, "frf-runs", "volt")
        page.fill("#frf-name", "chain")
        page.click("#frf-go")
        page.wait_for_selector("#frf-modes tbody tr", timeout=180_000)
        for plot in ("frf-mag", "frf-phase", "frf-coh"):
            wait_attr(page, f"svg[data-plot='{plot}']", "data-points", lambda v: int(v) > 100)
        assert "m/s/V" in page.get_attribute("svg[data-plot='frf-mag']", "aria-label")
        assert "(m/s/V)" in page.text_content("svg[data-plot='frf-mag']")
        assert "m/s/V" in page.text_content("#frf-modes-units")
        about = page.text_content("#frf-about")
        assert "velocity over voltage" in about and "/N" not in about
        rows = page.locator("#frf-modes tbody tr")
        got = [float(rows.nth(i).locator("td").nth(3).text_content()) for i in range(rows.count())]
        want = [m[0] for m in closed_modes(True)]
        assert got == pytest.approx(want, rel=2e-3)
        assert all("V" in rows.nth(i).locator("td").first.text_content() for i in range(rows.count()))

        _tick(page, "distortion-runs", "sine")
        _tick(page, "distortion-runs", "ms")
        page.click("#distortion-go")
        page.wait_for_selector("table.distortion tr[data-channel='acc']", timeout=120_000)
        cells = page.locator("table.distortion tr[data-channel='acc'] td")
        assert "m/s²" in cells.nth(2).text_content()
        h2 = float(cells.nth(3).text_content().split("±")[0])
        assert h2 == pytest.approx(sine_ratios()[2], rel=0.02)
        amp = page.locator("table.distortion tr[data-channel='amp'] td").nth(2).text_content()
        assert amp.endswith(" V")
        assert page.text_content("#distortion-summary-ms").startswith("nonlinear, odd,")

        wide = page.evaluate("() => document.documentElement.scrollWidth")
        assert wide <= width, f"page {wide} px wide in a {width} px viewport"
        box = page.locator("svg[data-plot='frf-mag']").bounding_box()
        assert box["width"] <= width and box["height"] > 50
        screenshot(page, f"frf-{width}")
        assert w.problems() == []
