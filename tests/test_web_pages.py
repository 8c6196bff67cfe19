"""Run and models pages in a real headless Chromium over a lab's worth of runs (issue 17
items 9 and 10): the legend keeps off the loop, aborted and incomplete runs say so, a
40 s run zooms and pans down to single samples, the run picker pages through a thousand
runs, cycle counts match the run, and the models page's plots draw what their legends
name, with NRMSE in one unit and unslanted labels that do not collide.
Screenshots go to test-artifacts/web/."""

from __future__ import annotations

import re

import pytest

from labjoint.api import ApiSettings, create_app
from test_api_helpers import CONTROL, live_server, wait_for
from test_web_support import chromium, open_page, screenshot, wait_attr
from web_catalog import BULK, CYCLES_50, LONG_FS, LONG_S, make_lab
from patience import http_client

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("lab")
    (tmp / "csv").mkdir()
    names = make_lab(tmp / "data", tmp / "csv")
    app = create_app(ApiSettings(data_dir=tmp / "data", control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1") as http, \
            chromium() as browser:
        yield url, http, browser, names


def _vertices(page, plot: str) -> list[tuple[float, float]]:
    """Every vertex of the plot's series paths, in the SVG's own coordinates."""
    ds = page.locator(f"svg[data-plot={plot}] path.series").evaluate_all(
        "ps => ps.map(p => p.getAttribute('d'))")
    pts = []
    for d in ds:
        nums = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?", d)]
        pts += list(zip(nums[::2], nums[1::2]))
    return pts


def test_the_legend_keeps_off_the_loop_and_cycle_counts_match_the_run(lab):
    url, http, browser, names = lab
    w = open_page(browser, url)
    page = w.page
    page.goto(f"{url}/#/run/{names['fifty']}")
    wait_attr(page, "svg[data-plot=loop]", "data-points", lambda v: int(v) > 100)
    box = page.locator("svg[data-plot=loop] .legend-bg").evaluate(
        "r => { const b = r.getBBox(); return [b.x, b.y, b.x + b.width, b.y + b.height]; }")
    pts = _vertices(page, "loop")
    assert len(pts) > 100
    under = [p for p in pts if box[0] <= p[0] <= box[2] and box[1] <= p[1] <= box[3]]
    assert not under, f"{len(under)} loop points under the legend {box}"
    # the caption states the cycles the run holds and the whole ones the pipeline found
    loops = http.get(f"/runs/{names['fifty']}/loops").json()
    caption = page.inner_text("#loop-caption")
    assert f"{CYCLES_50} cycles recorded" in caption
    assert f"{loops['n_cycles']} whole cycles" in caption and loops["n_cycles"] == CYCLES_50 - 1
    screenshot(page, "run-fifty-cycles")
    assert not w.problems(), w.problems()


@pytest.mark.parametrize("role, word", [("aborted", "Aborted"), ("incomplete", "Incomplete")])
def test_an_aborted_or_incomplete_run_says_so_and_shows_what_it_recorded(lab, role, word):
    url, http, browser, names = lab
    name = names[role]
    w = open_page(browser, url)
    page = w.page
    page.goto(f"{url}/#/run/{name}")
    page.wait_for_selector("#run-state")
    ch = http.get(f"/runs/{name}/channels").json()
    state = page.inner_text("#run-state")
    assert state.startswith(word) and f"{ch['n_samples']} samples" in state
    assert http.get(f"/runs/{name}").json()["status"] == role
    for c in ("disp_1", "shear_nc"):
        svg = f"svg[data-plot=raw-{c}]"
        assert int(wait_attr(page, svg, "data-points", int)) > 100
        # the signals span the whole recording, to its last sample
        assert float(page.get_attribute(svg, "data-xmax")) == pytest.approx(
            1e3 * (ch["n_samples"] - 1) / ch["sample_rate_hz"], abs=0.05)
    screenshot(page, f"run-{role}")
    assert not w.problems(), w.problems()


def test_a_long_run_zooms_and_pans_down_to_its_samples(lab):
    url, _, browser, names = lab
    w = open_page(browser, url)
    page = w.page
    page.goto(f"{url}/#/run/{names['long']}")
    sel = "svg[data-plot=raw-displacement]"
    assert wait_attr(page, sel, "data-window", lambda v: v == f"0,{LONG_S:g}")
    assert "decimated" in page.inner_text("#raw-caption")
    screenshot(page, "run-long-whole")
    span = LONG_S
    while span > 0.1:                                  # 40 s down to under 15 cycles
        page.click("#raw-zoom-in")
        span /= 2
        wait_attr(page, sel, "data-window",
                  lambda v: abs(float(v.split(",")[1]) - float(v.split(",")[0]) - span) < 1e-9)
    a, b = map(float, page.get_attribute(sel, "data-window").split(","))
    page.wait_for_selector("#raw-caption:has-text('Every sample')")
    n = int(page.get_attribute(sel, "data-points"))
    assert abs(n - (b - a) * LONG_FS) <= 2                  # every sample, not a band
    # one sine of 5 um: the trace reaches both peaks within the window
    assert float(page.get_attribute(sel, "data-ymax")) == pytest.approx(5.0, rel=0.02)
    assert float(page.get_attribute(sel, "data-ymin")) == pytest.approx(-5.0, rel=0.02)
    page.click("#raw-right")
    wait_attr(page, sel, "data-window", lambda v: float(v.split(",")[0]) == pytest.approx(a + span / 2))
    page.click("#raw-all")
    wait_attr(page, sel, "data-window", lambda v: v == f"0,{LONG_S:g}")
    assert not w.problems(), w.problems()


def test_the_run_picker_searches_and_pages_through_a_thousand_runs(lab):
    url, http, browser, _ = lab
    total = http.get("/runs", params={"status": "complete", "limit": 1}).json()["total"]
    assert total >= BULK
    w = open_page(browser, url)
    page = w.page
    page.goto(f"{url}/#/models")
    page.wait_for_selector("#run-pick input")
    assert page.inner_text("#run-page") == f"1–50 of {total}"
    assert page.locator("#run-pick input").count() == 50
    page.fill("#run-search", "bulk_09")                # bulk_0900 .. bulk_0999
    wait_for(lambda: page.inner_text("#run-page"), lambda t: t == "1–50 of 100", timeout=10)
    first = page.locator("#run-pick input").first.get_attribute("value")
    page.locator("#run-pick input").first.check()
    page.click("#run-next")
    wait_for(lambda: page.inner_text("#run-page"), lambda t: t == "51–100 of 100", timeout=10)
    assert page.is_disabled("#run-next")
    second = page.locator("#run-pick input").first.get_attribute("value")
    page.locator("#run-pick input").first.check()
    page.click("#run-prev")                                # ticks survive paging
    wait_for(lambda: page.inner_text("#run-page"), lambda t: t.startswith("1–50"), timeout=10)
    assert page.is_checked(f"#run-pick input[value={first}]")
    assert page.inner_text("#run-ticked") == "2 ticked"
    picked = page.evaluate("JSON.parse(sessionStorage.getItem('labjoint.selected'))")
    assert sorted(picked) == sorted([first, second])
    assert all(re.fullmatch(r"bulk_09\d\d", n) for n in picked)
    screenshot(page, "models-picker")
    assert not w.problems(), w.problems()


#: A diagnosis result shaped as the server sends it: 8 amplitude ranks whose rows
#: disagree (so the columns are labelled by ranges), a model with no dissipation.
RESULT = """{
  model: 'linear_stiffness', nrmse: 0.362, noise_floor: 0.00933, adequate: false,
  verdict: 'structure remains: the missing effect is not among the 2 tried (offset, inertia; 9 registered effects not tried)',
  candidates: [{ effect: 'viscous', significant: true, nrmse_after: 0.0181, nrmse_after_validation: 0.0289 }],
  by_run: { frequencies_hz: [100, 400],
    amplitude_m: [[0.7e-6, 1.2e-6, 2.1e-6, 3.3e-6, 4.25e-6, 5.5e-6, 7.32e-6, 9.9e-6],
                  [0.9e-6, 1.5e-6, 2.6e-6, 3.9e-6, 5.1e-6, 6.4e-6, 8.8e-6, 12.1e-6]],
    nrmse: [[0.36, 0.35, 0.36, 0.37, 0.36, 0.35, 0.34, 0.36], [0.3, 0.31, 0.32, 0.33, 0.3, 0.31, 0.32, 0.35]] },
  runs: [0.7, 2.1, 4.25, 7.32].map((u, i) => ({ run: `r${i}`, frequency_hz: 400, nrmse: 0.36,
    displacement_amplitude_m: u * 1e-6, energy_loss_measured_j: 1e-4 * u * u, energy_loss_model_j: 0,
    stiffness_measured_n_per_m: 1.15e7, stiffness_model_n_per_m: 1.14e7 })),
}"""


def test_models_plots_draw_what_their_legends_name_in_one_unit(lab):
    """The page's own drawing code in Chromium on a diagnosis-shaped result."""
    url, _, browser, _ = lab
    w = open_page(browser, url)
    page = w.page
    got = page.evaluate("""async () => {
      const d = await import('/static/js/views/modelplots.js');
      const r = %s;
      const box = document.createElement('div');
      document.body.append(box);
      box.append(d.summary(r, r), d.residualMaps({ by_run: r.by_run }, [], 'sine'), d.physics(r),
        d.ladderChart([{ model: 'linear_stiffness', nrmse: 0.362 }], 0.00933), d.perRun(r),
        d.candidates(r, () => {}, false));
      const rect = (e) => { const b = e.getBoundingClientRect(); return [b.left, b.top, b.right, b.bottom]; };
      const plot = (id) => {
        const svg = box.querySelector(`svg[data-plot=${id}]`);
        return { legend: [...svg.querySelectorAll('.legend-text')].map((t) => t.textContent),
          drawn: [...svg.querySelectorAll('[data-name]')].filter((e) => Number(e.dataset.drawn) > 0)
            .map((e) => e.dataset.name) };
      };
      return { labels: [...box.querySelectorAll('svg[data-plot=residual-grid] text.col-label')].map(rect),
        dissipation: plot('dissipation'), stiffness: plot('stiffness'),
        offScale: [...box.querySelectorAll('.off-scale')].map((e) => e.textContent),
        text: box.innerText };
    }""" % RESULT)
    labels = got["labels"]
    assert len(labels) == 8
    for a, b in zip(labels, labels[1:]):                 # neighbours do not collide
        assert a[2] <= b[0] + 0.5 or a[3] <= b[1] + 0.5 or b[3] <= a[1] + 0.5, (a, b)
    for p in ("dissipation", "stiffness"):
        assert got[p]["legend"] and set(got[p]["legend"]) <= set(got[p]["drawn"]), got[p]
    assert "model 400 Hz" not in got["dissipation"]["legend"]          # zero: not drawable
    assert any("model 400 Hz: not drawn" in t and "zero" in t for t in got["offScale"])
    assert "model 400 Hz" in got["stiffness"]["legend"]
    # NRMSE in % everywhere, never as a bare fraction
    text = got["text"]
    assert "36.2 %" in text and "0.933 %" in text and "1.81 %" in text
    assert not re.search(r"NRMSE[^\n%]*\b0\.\d+(?! %)", text.replace("·", "\n")), text
    assert "not among the 2 tried" in text
    assert not w.problems(), w.problems()
