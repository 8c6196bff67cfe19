"""The Structure view in a real headless Chromium: a diagnosis of a linear joint model on
an FRF set of a hidden Iwan + viscous joint draws measured and model FRFs per level and
the residual map per harmonic, with the verdict the job found."""

from __future__ import annotations

import pytest

from frfdata import hidden_law, hidden_set, predictor, write_linear_structure
from labjoint.api import ApiSettings, create_app
from test_api_helpers import CONTROL, live_server
from test_web_support import chromium, open_page, screenshot, wait_attr

pytestmark = pytest.mark.browser


def test_structure_view_draws_frfs_and_residual_maps(tmp_path):
    data = tmp_path / "data"
    (data / "structures").mkdir(parents=True)
    (data / "frf").mkdir()
    write_linear_structure(data / "structures" / "lin.toml")
    hidden_set(predictor(), hidden_law(), steps=5).save(data / "frf" / "sweep.json")
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    with live_server(app) as url, chromium() as browser:
        w = open_page(browser, url, token=CONTROL)
        page = w.page
        page.click("nav a[data-view=structure]")
        page.fill("#frf-candidates-input", "viscous")
        page.click("#frf-go")
        plot = "svg[data-plot='frf-mode1']"
        wait_attr(page, plot, "data-points", lambda v: int(v) > 0, timeout=180)
        names = page.locator(f"{plot} [data-name]").evaluate_all("els => els.map(e => e.dataset.name)")
        assert {"2 N up measured", "2 N model", "10 N up measured", "10 N model"} <= set(names)
        for hn in (1, 2, 3):
            cells = int(page.get_attribute(f"svg[data-plot='frf-residual-h{hn}']", "data-cells"))
            assert cells == 3 * 5                  # 3 levels x 5 steps
        summary = page.text_content("#frf-summary")
        assert "linear_stiffness" in summary and "add viscous" in summary
        assert page.text_content("#frf-failures").startswith("mode 1,")
        screenshot(page, "structure")
        assert w.problems() == []
