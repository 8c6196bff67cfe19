"""The Models view on a structure nobody can describe, in a real headless Chromium: two
force-driven random records of the 2-DOF chain (tests/spectra_runs.py: accelerations of
both masses, lsim from rest), its FRF set stored over REST as a user would from the FRFs
tab, then on the Models page the set chosen as the measured modes and
the linear modal model fitted and diagnosed: the jobs ran the modal kind on the named
response, the linear chain is reproduced (and called adequate), the ladder is drawn; a
band that is not two numbers is refused on the page naming options.modal_band. The same
chain driven through its strongly coupled coil (complex modes) shows the complex-mode
flag beside the fit, as the CLI's warning line does."""

from __future__ import annotations

import contextlib

import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.client import Client
from labjoint.storage import Catalog
from spectra_runs import random_force, random_voltage
from test_api_helpers import CONTROL, live_server
from test_web_support import chromium, open_page, wait_attr

pytestmark = pytest.mark.browser


@contextlib.contextmanager
def _models_page(tmp_path, write, names, responses=""):
    """The Models page on the runs ``write(path, seed)`` makes (seeds 3, 4, ...), their first
    run's FRF set made over REST as the measured modes, every run ticked, the linear model
    and cubic_stiffness as the only candidate; yields (page, watcher, client)."""
    data = tmp_path / "data"
    data.mkdir()
    for seed, name in enumerate(names, start=3):
        write(data / f"{name}.h5", seed)
    Catalog(data / "catalog.sqlite").rebuild(data)
    app = create_app(ApiSettings(data_dir=data, control_tokens=[CONTROL]))
    with live_server(app) as url, chromium() as browser, Client(url, CONTROL) as c:
        c.frf([names[0]], name="modes_set")
        w = open_page(browser, url, token=CONTROL)
        page = w.page
        page.goto(f"{url}/#/models")
        page.wait_for_selector(f"#run-pick input[value='{names[0]}']")
        for box in page.locator("#run-pick input").all():
            box.set_checked(box.get_attribute("value") in names)
        page.click("#modal-opts summary")
        page.select_option("#modal-set", "modes_set")
        page.fill("#modal-responses", responses)
        page.click("#limit summary")
        page.check("#limit input[value=cubic_stiffness]")
        page.fill("#model-expr", "linear_stiffness+viscous")
        yield page, w, c


def test_models_view_fits_and_diagnoses_on_measured_modes(tmp_path):
    force = lambda path, seed: random_force(path, 2.0, seed=seed, n=1 << 13)  # noqa: E731
    with _models_page(tmp_path, force, ("r1", "r2"), "acc1, acc2") as (page, w, c):
        page.click("#fit")
        wait_attr(page, "svg[data-plot=ladder]", "data-values", lambda v: v != "", 600)
        jobs = c.request("GET", "/models/jobs", params={"limit": 50})["items"]
        diag = next(j for j in jobs if j["kind"] == "model_diagnose" and j["status"] == "complete")
        res = c.request("GET", f"/models/jobs/{diag['id']}")["result"]
        assert res["kind"] == "modal" and res["measurement"] == "modal"
        assert res["nrmse"] < 0.02 and res["adequate"], (res["nrmse"], res["verdict"])
        assert sorted(res["fit_runs"] + res["validation_runs"]) == ["r1", "r2"]
        values = page.get_attribute("svg[data-plot=ladder]", "data-values").split(",")
        assert float(values[0]) == pytest.approx(100 * res["nrmse"], rel=1e-3)      # drawn in %
        # measured and model along each record, per compared sensor, in its own unit
        page.wait_for_selector("svg[data-plot^=overlay-]")
        overlays = page.locator("svg[data-plot^=overlay-]")
        assert overlays.count() == 4                                      # 2 records x 2 sensors
        assert "acceleration (m/s^2)" in overlays.first.text_content()
        assert int(overlays.first.get_attribute("data-series")) == 2
        # the residual per record and sensor, as the diagnosis measured it
        drawn = page.get_attribute("svg[data-plot=residual-cells]", "data-values").split(",")
        assert [float(v) for v in drawn] == pytest.approx(
            [100 * c["nrmse"] for c in res["maps"]["cells"]], rel=1e-3)
        assert len(drawn) == 4 and all(float(v) < 2 for v in drawn)
        assert w.problems() == []

        page.fill("#modal-band", "five:forty")
        page.click("#fit")
        page.wait_for_selector("#models-msg.error", timeout=60_000)
        assert "options.modal_band" in page.text_content("#models-msg")


def test_models_view_shows_the_measurement_flags(tmp_path):
    volts = lambda path, seed: random_voltage(path, 0.3, seed=seed, n=1 << 12)  # noqa: E731
    with _models_page(tmp_path, volts, ("v1", "v2")) as (page, w, _):
        page.click("#fit")
        page.wait_for_selector("#measurement-flags li[data-flag=complex_mode]", timeout=300_000)
        text = page.text_content("#measurement-flags")
        assert "mode 2" in text and "vel1" in text and "quadrature" in text
        assert w.problems() == []
