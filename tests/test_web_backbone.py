"""The Backbones view in a real headless Chromium, at 1400 and 390 px: a stored backbone
file with three methods drawn as points with error bars on a log amplitude axis (frequency
and damping ratio), and at 1400 px a ladder from a linear joint inside the structure
drawing each step's model curve, the linear damping it used and what remains after each
step (then shown at 390 px too); no page wider than the screen."""

from __future__ import annotations

import pytest

from backbonedata import measured, write
from frfdata import HIDDEN, predictor, write_linear_structure
from labjoint.api import ApiSettings, create_app
from labjoint.structure.law import JointLaw
from test_api_helpers import CONTROL, live_server
from test_web_support import chromium, open_page, screenshot, wait_attr

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    d = tmp_path_factory.mktemp("bbweb")
    for sub in ("structures", "backbones"):
        (d / sub).mkdir()
    write_linear_structure(d / "structures" / "lin.toml")
    pr = predictor()
    law = JointLaw("iwan", {k: v for k, v in HIDDEN.items() if k.startswith("iwan.")})
    write(d / "backbones" / "methods.json", measured(pr, law, n=7),
          measured(pr, law, n=9, lo=1e-5, hi=3e-4, seed=2, method="ringdown_hilbert"),
          measured(pr, law, n=3, lo=1e-4, hi=1e-3, seed=3, method="step_sine"))
    write(d / "backbones" / "pr.json", measured(pr, law, n=7))
    return d


def _names(page, plot):
    return page.locator(f"svg[data-plot='{plot}'] [data-name]").evaluate_all(
        "els => Object.fromEntries(els.map(e => [e.dataset.name, [e.dataset.drawn, e.dataset.bars || '0']]))")


@pytest.mark.parametrize("width", [1400, 390])
def test_backbone_view_points_by_method_and_ladder_curves(data, width):
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    with live_server(app) as url, chromium() as browser:
        w = open_page(browser, url, token=CONTROL)
        page = w.page
        page.set_viewport_size({"width": width, "height": 900})
        page.goto(f"{url}/#/backbone")
        page.wait_for_selector("#backbone-stored option[value='methods']", state="attached", timeout=60_000)
        page.select_option("#backbone-stored", "methods")
        page.click("#backbone-open")
        for plot in ("backbone-frequency", "backbone-damping"):
            wait_attr(page, f"svg[data-plot='{plot}']", "data-points", lambda v: int(v) == 19)
            got = _names(page, plot)
            assert got == {"phase resonance": ["7", "7"], "ringdown (Hilbert)": ["9", "9"],
                           "step sine": ["3", "3"]}, got       # every point with its error bar
            xmin = float(page.get_attribute(f"svg[data-plot='{plot}']", "data-xmin"))
            assert xmin == pytest.approx(1e-5, rel=1e-6)
        assert "(%)" in page.text_content("svg[data-plot='backbone-damping']")
        assert page.locator("#backbone-points tbody tr").count() == 19
        assert "mode 1, 19 point(s)" in page.text_content("#backbone-about")
        if width == 1400:
            page.select_option("#backbone-stored", "pr")
            page.click("#backbone-open")
            page.select_option("#backbone-structure", "lin")
            page.fill("#backbone-candidates", "iwan")
            page.fill("#backbone-steps", "1")
            page.click("#backbone-ladder-go")
            page.wait_for_selector("#backbone-ladder tbody tr[data-step='1']", timeout=600_000)
            got = _names(page, "backbone-frequency")
            assert got["step 0: linear_stiffness"][0] == "7"
            assert got["step 1: linear_stiffness+iwan"][0] == "7"
            assert "iwan" in page.text_content("#backbone-ladder tbody tr[data-step='1']")
            # the linear damping used, and what remains after the linear step (where: the
            # method and amplitude), in the ladder's own words
            assert "structure file" in page.text_content("#backbone-linear-damping")
            left = page.locator("#backbone-remaining [data-step='0'] li").all_text_contents()
            assert left and all("[" in t and " m" in t for t in left), left
            assert any(t.startswith(("frequency too", "damping too")) for t in left), left
            # the ladder's output on a phone: nothing wider than the screen
            page.set_viewport_size({"width": 390, "height": 900})
            wide = page.evaluate("() => document.documentElement.scrollWidth")
            assert wide <= 390, f"page {wide} px wide in a 390 px viewport with the ladder shown"
            screenshot(page, "backbone-ladder-390")
            page.set_viewport_size({"width": width, "height": 900})
        wide = page.evaluate("() => document.documentElement.scrollWidth")
        assert wide <= width, f"page {wide} px wide in a {width} px viewport"
        screenshot(page, f"backbone-{width}")
        assert w.problems() == []
