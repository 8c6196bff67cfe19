"""A day at the rig on the dashboard (issue 33 items 1-3, 11-13, 16), in a real headless
Chromium at a phone's width (390 px) and a desktop's (1400 px), against the service with
its daemon on the simulated rig: a multisine run shows Identify's refusal and its clipping
instead of loops and W; the Live page lists every job with Resume and Cancel; the STOPPED
banner leaves every page when the stop is cleared; no page is wider than a phone; a web
page of another origin cannot press the emergency stop; the Runs table shows results;
Trends keep 100 Hz and 400 Hz apart and list refusals by reason; a sliding friction test
and a friction coefficient from a clipped run are flagged (the page's own checks:
tests/test_web_checks.py). Screenshots: test-artifacts/web/."""

from __future__ import annotations

import contextlib
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Iterator

import pytest

import patience
from test_api_helpers import CONTROL, SHORT, wait_for
from test_web_support import FINISHED, chromium, open_page, run_plan, screenshot, site

pytestmark = pytest.mark.browser
WIDTHS = (390, 1400)
#: A multisine at 20 Vpp on the simulated rig: its reference force sits at the 250 N range.
MULTISINE = dict(f_min_hz=50, f_max_hz=1000, resolution_hz=20, n_periods=6, amplitude_vpp=20,
                 torque_nm=5, steady_max_periods=6)
LONG = {"plan": "dwell", "parameters": {"frequency_hz": 400, "amplitude_vpp": 4,
                                        "n_cycles": 200_000}}
SHORT_DWELL = {"plan": "dwell", "parameters": {"frequency_hz": 400, "amplitude_vpp": 2,
                                               "n_cycles": 40}}


@pytest.fixture(scope="module")
def day(tmp_path_factory):
    with site(tmp_path_factory.mktemp("day")) as s, chromium() as browser:
        ms = run_plan(s.http, "multisine", **MULTISINE)
        assert ms["status"] == "done", ms
        s.multisine = ms["runs"][0]
        low = run_plan(s.http, "amplitude_sweep", amplitudes_vpp=[4.0, 10.0, 20.0],
                       frequency_hz=100, torque_nm=5, **SHORT)
        assert low["status"] == "done", low
        s.low = low["runs"]
        yield s, browser


def _wide(page) -> tuple[int, int]:
    return page.evaluate("() => [document.documentElement.scrollWidth, window.innerWidth]")


@pytest.mark.parametrize("width", WIDTHS)
def test_a_multisine_run_shows_the_refusal_and_its_clipping_not_loops(day, width):
    """Item 1: no 'hysteresis loops of the steady cycles' at the line spacing, no W or K
    the pipeline refuses; the clipped reference force is named on the page."""
    s, browser = day
    name = s.multisine
    body = s.http.get(f"/runs/{name}/loops").json()
    assert body["cycles"] == [] and body["refused"] == "excitation", body["reason"]
    assert "multisine" in body["reason"]
    assert [c["channel"] for c in body["clipped"]] == ["force_ref"]
    assert abs(body["clipped"][0]["level"]) == pytest.approx(250, rel=1e-3)
    w = open_page(browser, s.url, token=CONTROL, width=width)
    page = w.page
    page.goto(f"{s.url}/#/run/{name}")
    page.wait_for_selector("#loop-refused")
    assert "multisine" in page.inner_text("#loop-refused")
    assert "steady cycles" not in page.inner_text("#loops-title")
    assert page.locator("svg[data-plot=loop]").count() == 0
    assert "force_ref" in page.inner_text("#run-clipped")
    conditions = page.inner_text("section.card:has(h2:text-is('Conditions'))")
    assert "multisine from 60 Hz to 1000 Hz, 48 lines: not a steady sine" in conditions
    assert "Excitation frequency" not in conditions
    page.click("#identification ~ .toolbar button.secondary")         # hysteresis loop only
    page.wait_for_selector("#identify-refused", timeout=patience.ms(30000))
    assert "multisine" in page.inner_text("#identify-refused")
    assert page.locator("#table2").count() == 0                      # no W, C, K quoted
    jobs = s.http.get("/analyses", params={"status": "complete"}).json()["items"]
    rows = [r for j in jobs for r in j["result"]["runs"] if r["run"] == name]
    assert rows and all("energy_loss_j" not in r and "multisine" in r["error"] for r in rows)
    assert _wide(page)[0] <= width
    screenshot(page, f"multisine-run-{width}")
    assert not w.problems(), w.problems()


def _views(s) -> list[tuple[str, str]]:
    return [("runs", "tr[data-run]"), (f"run/{s.sweep[-1]}", "svg[data-plot=loop]"),
            ("models", "#run-pick input"), ("predict", "main h1, main h2"),
            ("structure", "main h1, main h2"),
            ("trends?plan=amplitude_sweep", "#trends-table"), ("reprocess", "#reprocess-go"),
            ("live", "#jobs tr, #jobs p")]


@pytest.mark.parametrize("width", WIDTHS)
def test_no_page_is_wider_than_the_screen_and_the_runs_table_scrolls_inside(day, width):
    """Item 12: at 390 px every page fits the viewport; run names stay on one line; the
    columns right of Torque are reached by scrolling the table, not the page; the
    emergency stop and the status are on screen."""
    s, browser = day
    w = open_page(browser, s.url, width=width)
    page = w.page
    for view, ready in _views(s):
        page.goto(f"{s.url}/#/{view}")
        page.wait_for_selector(ready, timeout=patience.ms(60000))
        page.wait_for_timeout(300)
        doc, inner = _wide(page)
        assert doc <= inner, f"#{view} is {doc} px wide at {inner} px"
        box = page.locator("#estop").bounding_box()
        assert box and box["x"] >= 0 and box["x"] + box["width"] <= inner, view
        assert page.locator("#rig-output").inner_text().startswith("output"), view
        screenshot(page, f"phone-{view.split('?')[0].split('/')[0]}-{width}")
    page.goto(f"{s.url}/#/runs")
    page.wait_for_selector("tr[data-run]")
    heights = page.locator("tr[data-run] td:nth-child(2) a").evaluate_all(
        "as => as.map(a => [a.getClientRects().length, a.getBoundingClientRect().height,"
        " parseFloat(getComputedStyle(a).lineHeight) || 20])")
    assert heights and all(n == 1 and h < 1.6 * lh for n, h, lh in heights), heights
    last = page.locator("tr[data-run] td:last-child").first
    last.scroll_into_view_if_needed()
    box = last.bounding_box()
    assert box["x"] >= 0 and box["x"] + box["width"] <= width + 1
    assert _wide(page)[0] <= width                      # the table scrolled, not the page
    assert not w.problems(), w.problems()


@contextlib.contextmanager
def _foreign_page(target: str) -> Iterator[str]:
    """Another origin on loopback (another port): a page whose script POSTs the
    emergency stop to ``target`` as any web page can, with a no-cors fetch."""
    html = ("<!doctype html><title>elsewhere</title><script>"
            f"fetch('{target}/api/v1/estop', {{method: 'POST', mode: 'no-cors'}})"
            ".then(() => { document.title = 'sent'; }, () => { document.title = 'failed'; });"
            "</script>").encode()

    class Page(BaseHTTPRequestHandler):
        def do_GET(self) -> None:                  # noqa: N802 (http.server's name)
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(html)))
            self.end_headers()
            self.wfile.write(html)

        def log_message(self, *args) -> None:
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Page)
    t = threading.Thread(target=server.serve_forever, daemon=True)
    t.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


def test_a_page_of_another_origin_cannot_press_the_emergency_stop(day):
    """Item 16: a no-cors fetch from another page on this machine reaches the service
    with no token from loopback; it is refused for its Origin, so the rig runs on."""
    s, browser = day
    assert s.http.get("/rig").json()["estop"] is None
    ctx = browser.new_context()
    try:
        page = ctx.new_page()
        with _foreign_page(s.url) as evil:
            page.goto(evil)
            wait_for(lambda: page.title(), lambda t: t in ("sent", "failed"), timeout=10)
        assert page.title() == "sent"                    # the request went out...
        assert s.http.get("/rig").json()["estop"] is None   # ...and stopped nothing
        # the service's own page, token-less from loopback, does stop it (the exception)
        page.goto(f"{s.url}/#/runs")
        page.evaluate("() => fetch('/api/v1/estop', {method: 'POST', headers: "
                      "{'Content-Type': 'application/json'}, body: JSON.stringify({reason: 'own page'})})")
        assert wait_for(lambda: s.http.get("/rig").json()["estop"], bool, timeout=10) == "own page"
    finally:
        ctx.close()
        assert s.http.post("/estop/clear").status_code == 200


def _submit(s, plan: dict) -> str:
    r = s.http.post("/plans", json=plan)
    assert r.status_code == 202, r.text
    return r.json()["id"]


def _status(s, jid: str) -> str:
    return s.http.get(f"/plans/{jid}").json()["status"]


@pytest.mark.parametrize("width", WIDTHS)
def test_live_lists_every_job_and_the_stop_banner_leaves_every_page(day, width):
    """Item 11: a plan held by the stop and one queued while it was latched are both on
    the Live page with Resume and Cancel; the aborted run stays in view; the header's
    STOPPED leaves every page once the stop is cleared (here: by another client)."""
    s, browser = day
    running = _submit(s, LONG)
    recording = wait_for(lambda: s.http.get("/rig").json()["daemon"]["run"], bool, timeout=60)
    held = _submit(s, SHORT_DWELL)
    assert s.http.post("/estop", json={"reason": "day at the rig"}).status_code == 200
    wait_for(lambda: _status(s, running), lambda st: st in FINISHED, timeout=30)
    late = _submit(s, SHORT_DWELL)                               # while the stop is latched
    assert _status(s, held) == "held" and _status(s, running) == "aborted"
    aborted_run = recording
    assert s.http.get(f"/runs/{recording}").json()["status"] == "aborted"
    other = open_page(browser, s.url, width=width)               # a page that pressed nothing
    other.page.goto(f"{s.url}/#/models")
    other.page.wait_for_selector("#estop-msg.sent")
    assert "STOPPED" in other.page.inner_text("#estop-msg")
    w = open_page(browser, s.url, token=CONTROL, width=width)
    page = w.page
    page.goto(f"{s.url}/#/live")
    for jid in (running, held, late):
        page.wait_for_selector(f"#jobs-table tr[data-job='{jid}']")
    assert page.get_attribute(f"tr[data-job='{running}']", "data-status") == "aborted"
    assert page.locator(f"tr[data-job='{running}'] a", has_text=aborted_run).count() == 1
    queued_late = page.get_attribute(f"tr[data-job='{late}']", "data-status")
    assert queued_late in ("held", "queued")
    for jid in (held, late):
        assert page.locator(f"tr[data-job='{jid}'] button[data-action=cancel]").count() == 1
    assert page.locator(f"tr[data-job='{held}'] button[data-action=resume]").count() == 1
    assert page.locator(f"tr[data-job='{running}'] button").count() == 0
    assert _wide(page)[0] <= width
    screenshot(page, f"live-jobs-{width}")
    assert s.http.post("/estop/clear").status_code == 200        # cleared elsewhere
    other.page.wait_for_selector("#estop-msg:not(.sent)", state="attached", timeout=patience.ms(10000))
    assert "STOPPED" not in other.page.inner_text("#estop-msg")
    page.wait_for_selector("#estop-banner", state="hidden", timeout=patience.ms(10000))
    page.wait_for_selector("#estop-msg:not(.sent)", state="attached", timeout=patience.ms(10000))
    page.click(f"tr[data-job='{late}'] button[data-action=cancel]")
    wait_for(lambda: _status(s, late), lambda st: st == "cancelled", timeout=10)
    # the table re-renders (and may reorder) once it polls the cancel: click resume after
    # that, not on a row that moves under the pointer
    page.wait_for_selector(f"tr[data-job='{late}'][data-status=cancelled]", timeout=patience.ms(10000))
    page.click(f"tr[data-job='{held}'] button[data-action=resume]")
    assert wait_for(lambda: _status(s, held), lambda st: st in FINISHED, timeout=60) == "done"
    page.wait_for_selector(f"tr[data-job='{held}'][data-status=done]", timeout=patience.ms(10000))
    assert page.locator(f"tr[data-job='{running}'] a", has_text=aborted_run).count() == 1
    assert not w.problems(), w.problems()
    assert not other.problems(), other.problems()


def _reprocess_analyze(s) -> dict:
    """labjoint reprocess --pipeline analyze over the site's catalog, in this process."""
    from labjoint.batch.reprocess import SerialRunner, execute, plan_reprocess
    from labjoint.storage.results import Results
    cat = s.svc.app.state.catalog
    results = Results(cat)
    return execute(plan_reprocess(results, cat.query(), "analyze", {}), SerialRunner(), results)


@pytest.mark.parametrize("width", WIDTHS)
def test_the_runs_table_shows_each_runs_result_or_why_it_has_none(day, width):
    """Item 13: W, C, K of an analysed run; 'not applicable' for the multisine."""
    s, browser = day
    rep = _reprocess_analyze(s)
    assert rep["failed"] == 0, rep
    by = {r["run"]: r for r in rep["runs"]}
    assert by[s.multisine]["status"] in ("not_applicable", "skipped")
    w = open_page(browser, s.url, width=width)
    page = w.page
    page.wait_for_selector(f"tr[data-run='{s.multisine}'] td.result")
    res = page.locator(f"tr[data-run='{s.multisine}'] td.result")
    assert res.get_attribute("data-result") == "not_applicable"
    assert res.inner_text().startswith("not applicable") and "multisine" in res.inner_text()
    name = s.sweep[-1]
    stored = s.http.get("/runs", params={"search": name}).json()["items"][0]["result"]
    assert stored["status"] == "complete"
    cells = page.locator(f"tr[data-run='{name}'] td").all_inner_texts()
    assert cells[11] == "analysed"
    assert float(cells[8]) == pytest.approx(stored["energy_loss_j"] * 1e3, rel=1e-3)
    assert float(cells[9]) == pytest.approx(stored["damping_ns_per_m"], rel=1e-3)
    assert float(cells[10]) == pytest.approx(stored["stiffness_n_per_m"] * 1e-6, rel=1e-3)
    assert _wide(page)[0] <= width
    screenshot(page, f"runs-results-{width}")
    assert not w.problems(), w.problems()


@pytest.mark.parametrize("width", WIDTHS)
def test_trends_refuse_one_exponent_across_frequencies_and_list_refusals_by_reason(day, width):
    """Item 2: 100 Hz and 400 Hz sweeps get no common exponent; each series its own.
    Item 13: the runs Trends cannot analyse, grouped by reason."""
    s, browser = day
    body = s.http.get("/trends", params={"plan": "amplitude_sweep", "status": "complete"}).json()
    assert body["fit"]["error"] and "2 frequencies" in body["fit"]["error"], body["fit"]
    got = {(f["frequency_hz"], f["torque_nm"]): f for f in body["series_fits"]}
    assert set(got) == {(100.0, 5.0), (400.0, 5.0)}
    assert all(f["error"] is None and f["exponent"] > 1.5 for f in got.values()), got
    w = open_page(browser, s.url, width=width)
    page = w.page
    page.goto(f"{s.url}/#/trends?plan=amplitude_sweep&status=complete")
    page.wait_for_selector("#trend-series li")
    assert "no single exponent" in page.inner_text("#trend-exponent")
    items = page.locator("#trend-series li").evaluate_all(
        "ls => ls.map(l => [Number(l.dataset.frequency), Number(l.dataset.exponent)])")
    assert sorted(map(tuple, items)) == sorted((k[0], got[k]["exponent"]) for k in got)
    legend = page.locator("svg[data-plot=trend-energy_loss_j] .legend-text").evaluate_all(
        "ts => ts.map(t => t.textContent)")
    assert any("100 Hz" in t for t in legend) and any("400 Hz" in t for t in legend), legend
    assert _wide(page)[0] <= width
    screenshot(page, f"trends-series-{width}")
    page.goto(f"{s.url}/#/trends?status=complete")                 # every plan: refusals
    page.wait_for_selector("#trend-errors li")
    every = s.http.get("/trends", params={"status": "complete"}).json()["errors"]
    assert every and any(e["run"] == s.multisine for e in every)
    counts = page.locator("#trend-errors li").evaluate_all("ls => ls.map(l => Number(l.dataset.runs))")
    assert sum(counts) == len(every) and len(counts) <= len(every)
    assert "multisine" in page.inner_text("#trend-errors")
    assert not w.problems(), w.problems()


def test_a_friction_coefficient_from_a_clipped_run_is_flagged_where_it_is_used(day):
    """Item 3: mu identified from a clipped run (here, as if from the clipped multisine's
    record) is flagged in the analysis, in Trends and on the run page."""
    from labjoint.identify.identified import Identified, load_identified, save_identified
    s, browser = day
    good = load_identified(s.data_dir, "friction_coefficient")
    save_identified(s.data_dir, Identified("friction_coefficient", good.value, good.uncertainty,
                                           good.unit, s.multisine, "friction test (clipped)"))
    try:
        name = s.sweep[-1]
        w = open_page(browser, s.url, token=CONTROL)
        page = w.page
        page.goto(f"{s.url}/#/run/{name}")
        page.click("#identify-both")
        page.wait_for_selector("#friction-flag", timeout=patience.ms(60000))
        flag = page.inner_text("#friction-flag")
        assert s.multisine in flag and "clipped" in flag and "force_ref" in flag
        body = s.http.get("/trends", params={"run": s.sweep}).json()
        assert body["friction_flag"] and s.multisine in body["friction_flag"]
        assert any("clipped" in n for n in body["notes"])
        page.goto(f"{s.url}/#/trends?plan=amplitude_sweep&frequency_hz=400")
        page.wait_for_selector("#trends-table")
        assert "clipped" in page.inner_text("main")
        assert not w.problems(), w.problems()
    finally:
        save_identified(s.data_dir, good)
    body = s.http.get("/trends", params={"run": s.sweep}).json()
    assert body["friction_flag"] is None


@pytest.mark.parametrize("width", WIDTHS)
def test_a_friction_test_that_slides_is_not_given_a_zero_macro_slip_fraction(day, width):
    """Item 3: the simulated friction test's loop plateaus (gross slip); the stick-slip
    model takes K_t from the stick branches and finds the macro-slip the loop shows
    (it had K_t from the overall slope and said 0 %, which the page then flagged)."""
    s, browser = day
    name = s.http.get("/runs", params={"plan": "friction_test"}).json()["items"][0]["name"]
    w = open_page(browser, s.url, token=CONTROL, width=width)
    page = w.page
    page.goto(f"{s.url}/#/run/{name}")
    page.wait_for_selector("svg[data-plot=loop]")
    page.click("#identify-both")
    page.wait_for_selector("#table2", timeout=patience.ms(60000))
    text = page.inner_text("#identification")
    assert page.query_selector("#macro-slip-flag") is None
    assert "macro-slip fraction 100" in text and "macro-slip fraction 0.0 %" not in text
    assert _wide(page)[0] <= width
    screenshot(page, f"friction-run-{width}")
    assert not w.problems(), w.problems()
