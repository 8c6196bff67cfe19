"""The trends view (issue 17 item 11) in a real headless Chromium against the service
with an amplitude sweep recorded by the daemon on the simulated rig: it draws both
methods' series with their bars and the dissipation exponent from GET /trends, lays out
seed 002's tables beside the plots, and its CSV export holds exactly the REST numbers
(SVG and PNG exports are real files). Screenshots go to test-artifacts/web/."""

from __future__ import annotations

import csv
import io
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from test_web_support import SWEEP_VPP, chromium, open_page, screenshot, site, wait_attr

pytestmark = pytest.mark.browser
LOOP = "Hysteresis loop (measured)"
MODEL = "Stick-slip model (Eqs. 6-9)"
#: The REST query the view sends for a plan filter.
QUERY = {"plan": "amplitude_sweep", "status": "complete", "order": "excitation_vpp", "limit": 500}


@pytest.fixture(scope="module")
def web(tmp_path_factory):
    with site(tmp_path_factory.mktemp("trends-web")) as s, chromium() as browser:
        yield s, browser


def _points(page, plot: str, series: str) -> int:
    return page.locator(f"svg[data-plot={plot}] g[data-name='{series}'] circle").count()


def _download(page, button: str) -> Path:
    with page.expect_download() as dl:
        page.click(button)
    return Path(dl.value.path())


def test_trends_view_draws_both_methods_the_exponent_and_the_tables(web):
    s, browser = web
    body = s.http.get("/trends", params=QUERY).json()
    runs = body["runs"]
    assert [r["excitation_vpp"] for r in runs] == SWEEP_VPP and body["methods"] == ["loop", "stickslip"]
    w = open_page(browser, s.url)
    page = w.page
    page.click("nav a[data-view=trends]")
    page.select_option("#trend-filters select[name=plan]", "amplitude_sweep")
    page.click("#trend-show")
    wait_attr(page, "svg[data-plot=trend-energy_loss_j]", "data-points", lambda v: int(v) > 0)
    measured = [r for r in runs if not r["below_resolution"]]
    for q in ("energy_loss_j", "damping_ns_per_m"):
        assert _points(page, f"trend-{q}", LOOP) == len(measured)
        assert _points(page, f"trend-{q}", MODEL) == len(runs)
    assert _points(page, "trend-stiffness_n_per_m", LOOP) == len(runs)
    # default axis: force amplitude (log), the loop's exponent as REST fitted it
    assert page.input_value("#trend-axis") == "force_amplitude_n"
    shown = float(page.get_attribute("#trend-exponent", "data-exponent"))
    assert shown == body["fit"]["exponent"]
    lo, hi = body["fit"]["exponent_ci95"]
    assert f"{lo:.3g}" in page.inner_text("#trend-exponent") and "2.5-3" in page.inner_text(
        "#trend-exponent")
    # the plotted W span: the loop values in mJ (bars widen it a little)
    wmin = float(page.get_attribute("svg[data-plot=trend-energy_loss_j]", "data-ymin"))
    assert wmin <= min(min(r["energy_loss_j"], r["stickslip_energy_loss_j"]) for r in runs) * 1e3
    # seed 002 Table 3 beside the plots: three properties per excitation level
    table = page.locator("#trends-table tbody tr")
    assert table.count() == 3 * len(runs)
    top = runs[-1]
    cells = page.locator(f"#trends-table tr[data-run='{top['run']}'][data-property=energy_loss_j] td")
    assert cells.nth(0).inner_text() == f"{top['excitation_vpp']:g}"
    assert float(cells.nth(3).inner_text().split("±")[0]) == pytest.approx(
        top["energy_loss_j"] * 1e3, rel=1e-3)
    assert float(cells.nth(2).inner_text().split("±")[0]) == pytest.approx(
        top["stickslip_energy_loss_j"] * 1e3, rel=1e-3)
    box = page.locator("#trends-table").bounding_box()
    plots = page.locator("#trend-plots").bounding_box()
    assert box["x"] > plots["x"] + plots["width"] - 1         # beside, not below
    screenshot(page, "trends")
    # against the excitation: that fit; against the torque (one value): no exponent
    page.select_option("#trend-axis", "excitation_vpp")
    fit_v = next(f for f in body["fits"] if (f["method"], f["against"]) == ("loop", "excitation_vpp"))
    wait_attr(page, "#trend-exponent", "data-exponent", lambda v: v == str(fit_v["exponent"]))
    page.select_option("#trend-axis", "torque_nm")
    wait_attr(page, "#trend-exponent", "data-exponent", lambda v: v == "")
    assert "no exponent" in page.inner_text("#trend-exponent")
    assert not w.problems(), w.problems()


def test_exports_hold_the_rest_numbers(web):
    s, browser = web
    body = s.http.get("/trends", params=QUERY).json()
    w = open_page(browser, s.url)
    page = w.page
    page.goto(f"{s.url}/#/trends?plan=amplitude_sweep")
    wait_attr(page, "svg[data-plot=trend-energy_loss_j]", "data-points", lambda v: int(v) > 0)
    text = _download(page, "#export-csv").read_text()
    comments = [ln for ln in text.splitlines() if ln.startswith("#")]
    rows = list(csv.DictReader(io.StringIO("\n".join(ln for ln in text.splitlines()
                                                     if not ln.startswith("#")))))
    assert [r["run"] for r in rows] == [r["run"] for r in body["runs"]]
    for got, want in zip(rows, body["runs"]):
        for key, value in got.items():
            if key == "run" or want.get(key) is None:
                assert value == ("" if want.get(key) is None else want[key]), key
            elif isinstance(want[key], bool):
                assert value == str(want[key]).lower(), key
            else:
                assert float(value) == want[key], key          # exactly the REST number
    main = f"# loop_energy_loss_exponent_vs_force_amplitude_n: {body['fit']['exponent']!r}"
    assert any(c.startswith(main) for c in comments), comments
    svg = ET.fromstring(_download(page, "#export-svg").read_text())
    ns = "{http://www.w3.org/2000/svg}"
    assert len(svg.findall(f"{ns}svg")) == 3
    assert len(svg.findall(f".//{ns}circle")) >= 2 * len(body["runs"])
    assert svg.find(f".//{ns}circle").get("fill")                  # styles travel with it
    assert svg.find(f".//{ns}text").get("font-size")
    png = _download(page, "#export-png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    assert not w.problems(), w.problems()


def test_the_runs_ticked_on_the_runs_page_make_the_trend(web):
    s, browser = web
    w = open_page(browser, s.url)
    page = w.page
    page.wait_for_selector("tr[data-run]")
    picked = s.sweep[1:]
    for name in picked:
        page.check(f"tr[data-run='{name}'] input[type=checkbox]")
    page.click("nav a[data-view=trends]")
    page.check("#trend-filters input[name=ticked]")
    page.click("#trend-show")
    wait_attr(page, "svg[data-plot=trend-energy_loss_j]", "data-runs", lambda v: int(v) == len(picked))
    shown = page.locator("#trends-table tbody tr[data-property=energy_loss_j]").evaluate_all(
        "rows => rows.map(r => r.dataset.run)")
    assert sorted(shown) == sorted(picked)
    assert not w.problems(), w.problems()
