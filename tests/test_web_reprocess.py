"""The Reprocess view in a real headless Chromium: analyze over the simulated sweep's runs
as a job of the service (its Dask LocalCluster), each run's outcome shown as the job
reported it, and a second reprocess skipping every run whose result is current."""

from __future__ import annotations

import pytest

from test_api_helpers import wait_for
from test_web_support import chromium, open_page, site
import patience

pytestmark = pytest.mark.browser


def _statuses(page):
    rows = page.locator("#reprocess-runs tbody tr").evaluate_all(
        "els => els.map(e => [...e.children].map(c => c.textContent))")
    return {r[0]: r[2] for r in rows}


def test_reprocess_view_runs_a_pipeline_and_skips_current_results(tmp_path):
    with site(tmp_path) as s, chromium() as browser:
        w = open_page(browser, s.url, token=s.http.headers["Authorization"].split()[1])
        page = w.page
        page.click("nav a[data-view=reprocess]")
        page.select_option("#reprocess-pipeline", "analyze")
        page.fill("#reprocess-torque", "5")
        page.click("#reprocess-go")
        page.wait_for_selector("#reprocess-summary", timeout=patience.ms(180_000))
        shown = _statuses(page)
        job = s.http.get("/reprocess").json()["items"][0]
        assert job["status"] == "complete" and job["progress"] == 1.0
        assert shown == {r["run"]: r["status"] for r in job["result"]["runs"]}
        assert all(shown[n] == "computed" for n in s.sweep)        # the sweep's steady sines
        assert f"{job['result']['computed']} computed" in page.text_content("#reprocess-summary")
        page.click("#reprocess-go")
        wait_for(lambda: page.locator("#reprocess-summary").text_content()
                 if page.locator("#reprocess-summary").count() else "",
                 lambda t: t.startswith("0 computed"), timeout=120)
        assert all(_statuses(page)[n] == "skipped" for n in s.sweep)
        assert w.problems() == []
