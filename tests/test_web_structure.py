"""The Structure view in a real headless Chromium at a phone's width (390 px) and a
desktop's (1400 px) (issue 32 item 7): a diagnosis of a linear joint model on an FRF set
of a hidden Iwan + viscous joint (3 levels x 5 steps around mode 1) shows the verdict as
the job gives it, the effects not tried with their reason and the flagged parameters;
for every sensor a magnitude and a phase plot with every level overlaid (one colour per
level, named in the legend), the measured steps as points and the model as a curve of
many more points than the steps (harmonic balance between and around them: its peak
falls between the steps); the candidate's curves on selecting it; the residual maps; and
nothing wider than the screen."""

from __future__ import annotations

import numpy as np
import pytest

from frfdata import hidden_law, hidden_set, predictor, write_linear_structure
from labjoint.api import ApiSettings, create_app
from labjoint.structure.predict import synthetic_frfset
from test_api_helpers import CONTROL, live_server
from test_web_support import chromium, open_page, screenshot, wait_attr

pytestmark = pytest.mark.browser
SENSORS = ("coupling_short_side", "coupling_long_side", "free_end")
LEVELS = ("2 N up", "5 N up", "10 N up")
STEPS = 5


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    data = tmp_path_factory.mktemp("structweb") / "data"
    (data / "structures").mkdir(parents=True)
    (data / "frf").mkdir()
    write_linear_structure(data / "structures" / "lin.toml")
    pr = predictor()
    hidden_set(pr, hidden_law(), steps=STEPS).save(data / "frf" / "sweep.json")
    f0 = pr.natural_frequencies(1)[0]                # 3 steps 1.6 Hz apart across a 0.4 Hz peak
    synthetic_frfset(pr, hidden_law(), np.linspace(0.96 * f0, 1.04 * f0, 3), [2.0, 5.0, 10.0],
                     harmonics=3, noise=0.005, floor=1e-4, seed=2).save(data / "frf" / "coarse.json")
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    with live_server(app) as url, chromium() as browser:
        yield url, browser


def _plot(page, kind: str, sensor: str, hn: int = 1) -> str:
    return f"svg[data-plot='frf-{kind}-m1-{sensor}-h{hn}']"


def _names(page, sel: str) -> list[str]:
    return page.locator(f"{sel} [data-name]").evaluate_all("els => els.map(e => e.dataset.name)")


def _drawn(page, sel: str, name: str) -> int:
    return int(page.get_attribute(f"{sel} [data-name='{name}']", "data-drawn"))


def _xs_of_points(page, sel: str, name: str) -> list[float]:
    return page.locator(f"{sel} g[data-name='{name}'] circle").evaluate_all(
        "cs => cs.map(c => parseFloat(c.getAttribute('cx')))")


def _peak_x(page, sel: str, name: str) -> float:
    """Screen x of the model line's highest point (smallest y) in the magnitude plot."""
    d = page.get_attribute(f"{sel} path[data-name='{name}']", "d")
    pts = [tuple(map(float, seg.split())) for seg in d.replace("M", "L").split("L") if seg.strip()]
    return min(pts, key=lambda p: p[1])[0]


@pytest.mark.parametrize("width", [390, 1400])
def test_structure_view_draws_dense_model_curves_per_sensor_and_level(served, width):
    url, browser = served
    w = open_page(browser, url, token=CONTROL, width=width)
    page = w.page
    page.click("nav a[data-view=structure]")
    page.select_option("#frf-set", "sweep")
    page.fill("#frf-candidates-input", "viscous,offset,wear")
    page.click("#frf-go")
    page.wait_for_selector("#frf-verdict", timeout=240_000)
    # the verdict, the refusal and the candidates as the pipeline gives them
    verdict = page.text_content("#frf-verdict")
    assert verdict.startswith("add viscous: validation NRMSE"), verdict
    assert "linear_stiffness" in page.text_content("#frf-summary")
    refused = page.text_content("#frf-refused li[data-effect='wear']")
    assert refused.startswith("wear: cannot act in a structure's joint")
    assert page.text_content("#frf-failures").startswith("mode 1,")
    rows = page.locator("#frf-candidates tbody tr")
    cands = {rows.nth(i).locator("td").first.text_content(): rows.nth(i).locator("td").last.text_content()
             for i in range(rows.count())}
    # an even effect's constant cancels in this joint's moment: the pipeline flags both parameters
    assert cands == {"viscous": "–", "offset": "linear_stiffness.k, offset.F0"}, cands
    # every sensor: magnitude and phase, every level, measured points and a dense model curve
    for s in SENSORS:
        for kind in ("mag", "phase"):
            sel = _plot(page, kind, s)
            wait_attr(page, sel, "data-points", lambda v: int(v) > 0, timeout=240)
            names = set(_names(page, sel))
            assert {f"{lv} {what}" for lv in LEVELS for what in ("measured", "model")} <= names, names
            for lv in LEVELS:
                steps, model = _drawn(page, sel, f"{lv} measured"), _drawn(page, sel, f"{lv} model")
                assert steps == STEPS and model >= 20 * STEPS, (s, kind, lv, steps, model)
            assert page.get_attribute(sel, "data-model") == "linear_stiffness"
        mag = _plot(page, "mag", s)
        legend = page.locator(f"{mag} .legend-text").all_text_contents()
        assert legend == [f"{lv} model" for lv in LEVELS]
        colours = page.locator(f"{mag} path[data-name$=' model']").evaluate_all(
            "ps => ps.map(p => p.getAttribute('stroke'))")
        assert len(set(colours)) == len(LEVELS)
    # a curve, not a line through the steps: the model's peak lies between two steps
    mag = _plot(page, "mag", "free_end")
    xs = sorted(_xs_of_points(page, mag, "2 N up measured"))
    peak = _peak_x(page, mag, "2 N up model")
    assert min(abs(peak - x) for x in xs) > 2, (peak, xs)
    for hn in (1, 2, 3):
        cells = int(page.get_attribute(f"svg[data-plot='frf-residual-h{hn}']", "data-cells"))
        assert cells == 3 * STEPS
    # the candidate's curves on selecting it, with its parameters
    page.select_option("#frf-curve-pick", index=1)
    wait_attr(page, mag, "data-model", lambda v: v == "linear_stiffness+viscous", timeout=240)
    assert page.locator("#params tr[data-param='viscous.c']").count() == 1
    screenshot(page, f"structure-h1-{width}")
    labels = page.locator("#frf-curve-pick option").all_text_contents()
    page.select_option("#frf-curve-pick", index=next(i for i, x in enumerate(labels) if x.startswith("+ offset")))
    wait_attr(page, mag, "data-model", lambda v: v == "linear_stiffness+offset", timeout=240)
    flag = page.get_attribute("#params tr[data-param='offset.F0']", "data-flag")
    assert flag.startswith("undetermined") and flag in page.text_content("#params tr[data-param='offset.F0']")
    page.select_option("#frf-curve-pick", index=1)
    wait_attr(page, mag, "data-model", lambda v: v == "linear_stiffness+viscous", timeout=240)
    page.select_option("#frf-harmonic", "2")
    page.wait_for_selector(_plot(page, "mag", "free_end", 2))
    # a linear law has no second harmonic: the solver's round-off is not drawn as a response
    assert page.locator("figure.frf-curve figcaption").count() == len(SENSORS)
    assert _drawn(page, _plot(page, "mag", "free_end", 2), "2 N up model") == 0
    # nothing wider than the screen
    page.wait_for_timeout(200)
    doc, inner = page.evaluate("() => [document.documentElement.scrollWidth, window.innerWidth]")
    assert doc <= inner, f"the structure view is {doc} px wide at {inner} px"
    for s in SENSORS:
        box = page.locator(_plot(page, "phase", s).replace("-h1", "-h2")).bounding_box()
        assert box and box["x"] >= 0 and box["x"] + box["width"] <= inner and box["height"] > 80
    # no text of a plot runs past its own frame (an SVG clips it without widening the page)
    past = page.locator("#frf-plots svg.plot text, #frf-maps svg.plot text").evaluate_all(
        "ts => ts.filter(t => { const b = t.getBoundingClientRect(),"
        " v = t.ownerSVGElement.getBoundingClientRect();"
        " return b.left < v.left - 0.5 || b.right > v.right + 0.5; }).map(t => t.textContent)")
    assert past == [], past
    screenshot(page, f"structure-{width}")
    assert w.problems() == []


def test_a_ladder_from_the_page_draws_each_steps_curves(served):
    """The ladder from the page: its steps, the final diagnosis's verdict and the reason it
    stopped; the last step's curves drawn first, an earlier step's on selecting it."""
    url, browser = served
    w = open_page(browser, url, token=CONTROL, width=1400)
    page = w.page
    page.click("nav a[data-view=structure]")
    page.select_option("#frf-set", "sweep")
    page.fill("#frf-candidates-input", "viscous")
    page.select_option("#frf-op", "ladder")
    page.click("#frf-go")
    page.wait_for_selector("#frf-steps tbody tr", timeout=480_000)
    steps = page.locator("#frf-steps tbody tr td:nth-child(3)").all_text_contents()
    assert steps[:2] == ["linear_stiffness", "linear_stiffness+viscous"], steps
    assert page.text_content("#frf-stop").startswith("ladder stopped: ")
    assert page.text_content("#frf-verdict").strip()
    mag = _plot(page, "mag", "free_end")
    wait_attr(page, mag, "data-model", lambda v: v == steps[-1], timeout=240)
    page.select_option("#frf-curve-pick", index=0)
    wait_attr(page, mag, "data-model", lambda v: v == "linear_stiffness", timeout=240)
    assert _drawn(page, mag, "10 N up model") >= 20 * STEPS
    assert w.problems() == []


def test_a_coarse_set_gets_the_inconclusive_verdict_as_the_pipeline_words_it(served):
    """Three steps 1.6 Hz apart across a resonance whose half-power band is 0.4 Hz: viscous
    lowers the error a lot but the test is weak; the page says "inconclusive" and what to
    measure, in the job's words, and still draws the model's curve through the gap."""
    url, browser = served
    w = open_page(browser, url, token=CONTROL, width=390)
    page = w.page
    page.click("nav a[data-view=structure]")
    page.select_option("#frf-set", "coarse")
    page.fill("#frf-candidates-input", "viscous")
    page.click("#frf-go")
    page.wait_for_selector("#frf-verdict", timeout=240_000)
    verdict = page.text_content("#frf-verdict")
    assert verdict.startswith("inconclusive: viscous lowers the validation NRMSE"), verdict
    assert "sample the resonance more densely (<= " in verdict
    assert "bad" not in page.get_attribute("#frf-verdict", "class")
    assert page.locator("#frf-candidates tbody tr td").nth(2).text_content() == "no"
    mag = _plot(page, "mag", "free_end")
    wait_attr(page, mag, "data-points", lambda v: int(v) > 0, timeout=240)
    assert _drawn(page, mag, "5 N up measured") == 3 and _drawn(page, mag, "5 N up model") >= 60
    doc, inner = page.evaluate("() => [document.documentElement.scrollWidth, window.innerWidth]")
    assert doc <= inner
    screenshot(page, "structure-inconclusive-390")
    assert w.problems() == []
