"""The dashboard in a real headless Chromium against a real uvicorn on loopback, with
runs recorded by the daemon on the simulated rig: pages load with no console errors and
no off-site request, plots carry the data, the live view follows a recording and stops
it, and adding a missing effect grows the ladder by one step with a lower NRMSE.
Screenshots go to test-artifacts/web/."""

from __future__ import annotations

import json

import pytest

from test_api_helpers import CONTROL, wait_for
from test_web_support import (SWEEP_VPP, chromium, open_page, run_plan, screenshot, site,
                              wait_attr)
import patience

pytestmark = pytest.mark.browser
#: Candidate effects the model test lets the page try (a micro-slip joint's usual suspects).
TRY = ("viscous", "coulomb")


@pytest.fixture(scope="module")
def web(tmp_path_factory):
    with site(tmp_path_factory.mktemp("web")) as s, chromium() as browser:
        yield s, browser


def _cell(page, row_label: str, col: int) -> str:
    return page.locator(f"#table2 tr:has(td:text-is('{row_label}')) td").nth(col).inner_text()


def test_runs_list_filters_and_run_page(web):
    s, browser = web
    w = open_page(browser, s.url, token=CONTROL)
    page = w.page
    page.wait_for_selector("tr[data-run]")
    listed = page.locator("tr[data-run]").evaluate_all("rows => rows.map(r => r.dataset.run)")
    assert set(s.sweep) <= set(listed)
    page.select_option("#run-filters select[name=plan]", "amplitude_sweep")
    page.fill("#run-filters input[name=vpp_min]", "10")
    page.click("#run-filters button[type=submit]")
    rows = "tr[data-run]"
    wait_for(lambda: page.locator(rows).evaluate_all("rs => rs.map(r => r.dataset.run)"),
             lambda names: names == [n for n, v in zip(s.sweep, SWEEP_VPP) if v >= 10][::-1],
             timeout=10)                                   # newest first
    screenshot(page, "runs-filtered")
    page.fill("#run-filters input[name=until]", "2000-01-01")
    page.click("#run-filters button[type=submit]")
    page.wait_for_selector("p.note:has-text('No run matches')")
    assert page.locator(rows).count() == 0
    page.goto(f"{s.url}/#/runs")

    name = s.sweep[-1]                                       # 20 Vpp
    page.click(f"tr[data-run='{name}'] a")
    wait_attr(page, "svg[data-plot=loop]", "data-points", lambda v: int(v) > 100)
    # the loops drawn are the steady cycles the server found, each closed on itself
    steady = s.http.get(f"/runs/{name}/loops", params={"max_cycles": 8,
                                                       "points_per_cycle": 200}).json()
    loop = page.locator("svg[data-plot=loop]")
    assert loop.get_attribute("data-source") == "steady"
    assert int(loop.get_attribute("data-cycles")) == len(steady["cycles"]) > 0
    assert int(loop.get_attribute("data-points")) == sum(len(c["displacement_m"]) + 1
                                                         for c in steady["cycles"])
    u_um = [v * 1e6 for c in steady["cycles"] for v in c["displacement_m"]]
    assert float(loop.get_attribute("data-xmin")) == pytest.approx(min(u_um), rel=1e-6)
    assert page.locator("#loop-cycles tbody tr").count() == len(steady["cycles"])
    for ch in ("force_ref", "disp_1", "disp_2", "shear_nc"):
        assert int(wait_attr(page, f"svg[data-plot=raw-{ch}]", "data-points", int)) > 100
    page.click("#identify-both")
    page.wait_for_selector("#table2", timeout=patience.ms(30000))
    row = next(r for r in _analysis(s, name, "both")["runs"] if r["run"] == name)
    # displayed at the edge in um, mJ, Ns/m: the loop plot spans about +-U
    xmin = float(page.get_attribute("svg[data-plot=loop]", "data-xmin"))
    xmax = float(page.get_attribute("svg[data-plot=loop]", "data-xmax"))
    assert (xmax - xmin) / 2 == pytest.approx(row["displacement_amplitude_m"] * 1e6, rel=0.1)
    loop_mj = float(_cell(page, "Energy loss", 3).split("±")[0])
    assert loop_mj == pytest.approx(row["energy_loss_j"] * 1e3, rel=1e-3)
    ss_damping = float(_cell(page, "Joint damping", 2))
    assert ss_damping == pytest.approx(row["stickslip_damping_ns_per_m"], rel=1e-3)
    # the stick-slip column says it is a model value, fixed by the loop's stiffness
    assert "Stick-slip model" in page.inner_text("#table2 thead")
    assert "not an independent confirmation" in page.inner_text("#table2-basis")
    screenshot(page, "run-page")
    assert not w.problems(), w.problems()


def _analysis(s, name: str, method: str) -> dict:
    jobs = s.http.get("/analyses", params={"status": "complete"}).json()["items"]
    job = next(j for j in jobs if name in j["request"]["runs"] and j["request"]["method"] == method)
    return job["result"]


def test_live_view_follows_a_recording_and_stops_it(web):
    s, browser = web
    w = open_page(browser, s.url, token=CONTROL)
    page = w.page
    page.goto(f"{s.url}/#/live")
    page.wait_for_selector("#plan-type option[value=dwell]", state="attached")
    page.select_option("#plan-type", "dwell")
    page.fill("#plan-params", json.dumps({"frequency_hz": 400, "amplitude_vpp": 8,
                                          "n_cycles": 200_000}))
    page.click("#plan-submit")
    sel = "svg[data-plot=live-loop-plot]"
    wait_attr(page, sel, "data-points", lambda v: int(v) > 100)
    first = int(wait_attr(page, sel, "data-samples", lambda v: int(v) > 0))
    later = int(wait_attr(page, sel, "data-samples", lambda v: int(v) > first))
    assert later > first                                  # the loop follows the recording
    assert page.inner_text("#output-state") == "ON"
    screenshot(page, "live-recording")
    # the recording's own run page: its last cycles as recorded, not (yet) steady ones
    recording = s.http.get("/rig").json()["daemon"]["run"]
    other = open_page(browser, s.url)
    other.page.goto(f"{s.url}/#/run/{recording}")
    wait_attr(other.page, "svg[data-plot=loop]", "data-points", lambda v: int(v) > 100)
    assert other.page.get_attribute("svg[data-plot=loop]", "data-source") == "raw"
    assert not other.problems(), other.problems()
    other.page.context.close()
    page.click("#estop")
    page.wait_for_selector("#estop-banner:not([hidden])")
    page.wait_for_selector("#plan-status.aborted", timeout=patience.ms(30000))
    rig = s.http.get("/rig").json()
    assert rig["daemon"]["generator"]["output"] is False and rig["estop"]
    screenshot(page, "live-estopped")
    page.click("#estop-clear")
    wait_for(lambda: s.http.get("/rig").json()["estop"], lambda e: e is None, timeout=10)
    # the long recording, on its run page: raw signals min/max decimated for the screen
    page.click("#plan-box a")
    n = int(wait_attr(page, "svg[data-plot=raw-disp_1]", "data-points", int))
    assert 100 < n <= 1500 < later
    assert "decimated" in page.inner_text("#raw .caption")
    assert not w.problems(), w.problems()


def test_without_the_token_only_the_emergency_stop_is_sent_from_this_machine(web):
    """The stop is in the header of every page and works without a token from the
    machine itself (loopback); clearing it still needs the token, refused in the page."""
    s, browser = web
    w = open_page(browser, s.url)
    page = w.page
    page.goto(f"{s.url}/#/models")
    page.wait_for_selector("#estop")
    page.click("#estop")
    page.wait_for_selector("#estop-msg.sent")
    assert s.http.get("/rig").json()["estop"] == "emergency stop from the dashboard"
    screenshot(page, "estop-from-any-page")
    page.goto(f"{s.url}/#/live")
    page.wait_for_selector("#estop-banner:not([hidden])")
    page.click("#estop-clear")
    page.wait_for_selector("#live-msg.error")
    assert "control token" in page.inner_text("#live-msg")
    assert s.http.post("/estop/clear").status_code == 200
    assert not w.problems(), w.problems()       # refused in the page: no 401 on the wire


@pytest.mark.slow
def test_adding_a_candidate_grows_the_ladder_with_lower_nrmse(web):
    s, browser = web
    w = open_page(browser, s.url, token=CONTROL)
    page = w.page
    page.goto(f"{s.url}/#/models")
    page.wait_for_selector("#run-pick input")
    for box in page.locator("#run-pick input").all():
        box.set_checked(box.get_attribute("value") in s.sweep)
    page.click("#limit summary")          # the full vocabulary takes ~1 min per diagnosis
    for effect in TRY:
        page.check(f"#limit input[value={effect}]")
    page.fill("#model-expr", "linear_stiffness")
    page.click("#fit")
    first = wait_attr(page, "svg[data-plot=ladder]", "data-values", lambda v: v != "", 120)
    assert len(first.split(",")) == 1
    assert int(wait_attr(page, "svg[data-plot=residual-grid]", "data-cells", int)) == len(s.sweep)
    assert int(page.get_attribute("svg[data-plot=dissipation]", "data-points")) >= len(s.sweep)
    assert page.locator("svg[data-plot^=overlay-]").count() == len(s.sweep)
    # the overlays are the diagnosis's own loops: no separate fit was needed
    kinds = {j["kind"] for j in s.http.get("/models/jobs", params={"limit": 500}).json()["items"]}
    assert "model_diagnose" in kinds and "model_fit" not in kinds
    offered = page.locator("#candidates li").evaluate_all("els => els.map(e => e.dataset.effect)")
    assert set(offered) <= set(TRY) and offered
    button = page.locator("#candidates li.significant button.add-effect").first
    if not button.count():
        button = page.locator("#candidates button.add-effect").first
    effect = button.get_attribute("data-effect")
    screenshot(page, "models-fit")
    button.click()
    steps = wait_attr(page, "svg[data-plot=ladder]", "data-values",
                      lambda v: len(v.split(",")) == 2, 180).split(",")
    assert float(steps[1]) < float(steps[0])
    assert page.input_value("#model-expr") == f"linear_stiffness+{effect}"
    screenshot(page, "models-ladder")
    assert not w.problems(), w.problems()


def test_a_multisine_record_is_judged_along_its_history_on_the_models_page(web, tmp_path):
    """An imported multisine (a 2 kg mass on a spring and damper, force in, displacement
    out) diagnosed as a record: its maps by run, band and line, the force along the record
    for the fit and validation parts, and the missing mass named."""
    from labjoint.storage import import_csv
    from labjoint.storage.catalog import Catalog
    from test_excitation_refusal import _multisine_csv
    s, browser = web
    name = import_csv(_multisine_csv(tmp_path, periods=6), s.data_dir, name="multisine_sdof",
                      catalog=Catalog(s.data_dir / "catalog.sqlite")).stem
    w = open_page(browser, s.url, token=CONTROL)
    page = w.page
    page.goto(f"{s.url}/#/models")
    page.wait_for_selector(f"#run-pick input[value={name}]")
    for box in page.locator("#run-pick input").all():
        box.set_checked(box.get_attribute("value") == name)
    page.click("#limit summary")
    page.check("#limit input[value=inertia]")
    page.fill("#model-expr", "linear_stiffness+viscous")
    page.click("#fit")
    wait_attr(page, "svg[data-plot=ladder]", "data-values", lambda v: v != "", 120)
    for plot in ("residual-runs", "residual-bands", "residual-lines"):
        assert page.locator(f"svg[data-plot={plot}]").count() == 1, plot
    assert page.locator("svg[data-plot=residual-grid]").count() == 0   # no sine grid
    assert page.locator("svg[data-plot^=overlay-]").count() == 2        # fit and validation parts
    offered = page.locator("#candidates li.significant").evaluate_all(
        "els => els.map(e => e.dataset.effect)")
    assert offered == ["inertia"]
    screenshot(page, "models-record")
    assert not w.problems(), w.problems()


def test_models_page_shows_a_saved_ladder_without_recomputing(web):
    s, browser = web
    r = s.http.post("/models/ladder", json={"runs": s.sweep, "model": "linear_stiffness",
                                            "max_steps": 1, "options": {"candidates": ["coulomb"]}})
    assert r.status_code == 202, r.text
    job = wait_for(lambda: s.http.get(f"/models/jobs/{r.json()['id']}").json(),
                   lambda j: j["status"] in ("complete", "failed"), timeout=60)
    assert job["status"] == "complete", job["error"]
    steps = job["result"]["steps"]
    w = open_page(browser, s.url)                    # reading needs no token
    page = w.page
    page.goto(f"{s.url}/#/models")
    page.wait_for_selector("#run-pick input")
    jobs_before = len(s.http.get("/models/jobs").json()["items"])
    for box in page.locator("#run-pick input").all():
        box.set_checked(box.get_attribute("value") in s.sweep)
    card = f".saved-ladder[data-key='{job['result']['key']}']"
    wait_for(lambda: page.locator(f"{card} .caption").all_text_contents(),
             lambda t: t and t[0].startswith("These runs"), timeout=20)   # saved on exactly these
    sel = f"{card} svg[data-plot^=saved-ladder-]"
    values = wait_attr(page, sel, "data-values", lambda v: v != "", 20).split(",")
    # NRMSE in % on the page
    assert [float(v) for v in values] == pytest.approx([100 * st["nrmse"] for st in steps], rel=1e-9)
    label = page.locator(sel).locator("text.hline-label").text_content()   # the floor drawn
    assert label.startswith("noise floor") and label.endswith(" %")
    assert float(label.split()[-2]) == pytest.approx(100 * job["result"]["noise_floor"], rel=5e-3)
    page.locator(f"{card} button.use-ladder").click()
    main = wait_attr(page, "svg[data-plot=ladder]", "data-values", lambda v: v != "", 10)
    assert main == ",".join(values)
    assert page.input_value("#model-expr") == job["result"]["final_model"]
    assert len(s.http.get("/models/jobs").json()["items"]) == jobs_before   # nothing recomputed
    screenshot(page, "models-saved-ladder")
    assert not w.problems(), w.problems()


def test_plot_axes_and_display_units_in_the_browser(web):
    """The page's own modules, imported in Chromium: log axes place values by their
    logarithm and label a sensible number of ticks; SI values convert at the edge."""
    s, browser = web
    w = open_page(browser, s.url)
    got = w.page.evaluate("""async () => {
      const { axis } = await import('/static/js/plot/axes.js');
      const u = await import('/static/js/units.js');
      const ax = (lo, hi, log) => { const a = axis(lo, hi, 0, 600, { log });
        return { domain: a.domain, ticks: a.ticks, mid: a.map(Math.sqrt(lo * hi)),
                 ends: [a.map(lo), a.map(hi)], lin_mid: a.map((lo + hi) / 2) }; };
      return { amp: ax(0.632, 7.06, true), wide: ax(1e-13, 1, true), narrow: ax(12.6, 13.9, true),
               force: ax(-88.8, 88.8, false),
               units: ['m', 'J', 'N/m', 'N s/m', 'N'].map((x) => [u.display(x).unit, u.display(x).k]) };
    }""")
    for name, (dlo, dhi) in {"amp": (0.632, 7.06), "wide": (1e-13, 1), "narrow": (12.6, 13.9)}.items():
        a = got[name]
        lo, hi = a["domain"]
        assert lo <= dlo and hi >= dhi                     # the data fit inside
        assert all(lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9) for t in a["ticks"])
        assert a["ticks"] == sorted(a["ticks"]) and 3 <= len(a["ticks"]) <= 9, a["ticks"]
        # geometric mean of the data halfway between them on the screen: a log scale
        assert a["mid"] == pytest.approx(sum(a["ends"]) / 2, abs=1e-6)
    f = got["force"]
    assert 0 in f["ticks"] and f["domain"][0] == -f["domain"][1]
    assert f["lin_mid"] == pytest.approx(sum(f["ends"]) / 2)
    assert got["units"] == [["µm", 1e6], ["mJ", 1e3], ["MN/m", 1e-6], ["Ns/m", 1], ["N", 1]]
    assert not w.problems(), w.problems()
