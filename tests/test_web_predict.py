"""The Predict view (issue 14) in a real headless Chromium: it fits a model with inertia
by simulation error on a ticked record and plots measured against predicted displacement
on a held-out record, with the parameters the page shows equal to the job's result."""

from __future__ import annotations

import pytest

from labjoint.storage.catalog import Catalog
from labjoint.storage.csv_import import import_csv
from test_api_simulation import EXPR, TRUE, write_record
from test_web_support import chromium, open_page, screenshot, site, wait_attr

pytestmark = pytest.mark.browser


def test_predict_view_fits_on_one_record_and_predicts_another(tmp_path):
    with site(tmp_path) as s, chromium() as browser:
        cat = Catalog(s.data_dir / "catalog.sqlite")
        for i in (1, 2):
            import_csv(write_record(tmp_path, f"ms{i}", i), s.data_dir, name=f"ms{i}", catalog=cat)
        w = open_page(browser, s.url, token=s.http.headers["Authorization"].split()[1])
        page = w.page
        page.click("nav a[data-view=predict]")
        page.check("#predict-fit input[value=ms1]")
        page.check("#predict-validate input[value=ms2]")
        page.fill("#predict-model", EXPR)
        page.click("#predict-go")
        plot = "svg[data-plot='predict-held-out-ms2']"
        wait_attr(page, plot, "data-points", lambda v: int(v) > 0, timeout=120)
        names = page.locator(f"{plot} [data-name]").evaluate_all("els => els.map(e => e.dataset.name)")
        assert {"measured", "predicted", "residual"} <= set(names)
        cells = page.locator("#predict-params tbody tr").evaluate_all(
            "rows => rows.map(r => [...r.cells].map(c => c.textContent))")
        shown = {r[0]: float(r[1]) for r in cells}
        assert shown["inertia.m"] == pytest.approx(TRUE["inertia.m"], rel=0.01)
        assert {r[0]: r[3] for r in cells}["inertia.m"] == "kg"
        assert "held-out" in page.text_content("#predict-summary")
        assert "%" in page.text_content("#predict-summary")
        screenshot(page, "predict")
        assert w.problems() == []
