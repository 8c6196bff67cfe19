"""REST and client: backbones of catalogued phase-resonance runs of the simulated structural
rig, the same as the library's; unknown runs and bad bodies refused."""

from __future__ import annotations

import glob
from pathlib import Path

import pytest

from labjoint.acquisition.plans_resonance import phase_resonance
from labjoint.api import ApiSettings, create_app
from labjoint.client import ApiError, Client
from labjoint.identify.backbone import measured_backbones
from labjoint.storage import Catalog
from structure_runs import run_plans
from test_api_helpers import CONTROL, READ, live_server


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    d = tmp_path_factory.mktemp("backbones")
    plan = phase_resonance([0.5, 2.0], 28.0, (20.0, 35.0), response_channel="free_end", measure_cycles=10,
                           n_cycles=40, steady_max_cycles=100, ringdown_s=4.0)
    assert run_plans(d, [(plan, "pr")])[0].status == "complete"
    Catalog(d / "catalog.sqlite").rebuild(d)
    app = create_app(ApiSettings(data_dir=d, control_tokens=[CONTROL], read_tokens=[READ]))
    with live_server(app) as url:
        yield url, d


@pytest.mark.slow
def test_backbones_of_runs_through_the_client(served):
    url, d = served
    files = sorted(glob.glob(str(d / "*.h5")))
    names = [Path(f).stem for f in files]
    with Client(url, CONTROL) as c:        # a computation on demand: the control token, as analyses
        got = c.backbones(names)
        assert got["sensor"] == "free_end"
        expect = measured_backbones(files)
        # the ringdown's two estimators are two backbones, never one merged curve
        assert [{p.method for p in b.points} for b in expect] == [
            {"phase_resonance"}, {"ringdown_hilbert"}, {"ringdown_peaks"}]
        pts = [p.to_dict(b.amplitude_units) for b in expect for p in b.points]
        assert [p["method"] for p in got["points"]] == [p["method"] for p in pts]
        assert [p["frequency_hz"] for p in got["points"]] == pytest.approx([p["frequency_hz"] for p in pts])
        assert {p["method"] for p in got["points"]} >= {"phase_resonance", "ringdown_hilbert", "ringdown_peaks"}
        with pytest.raises(ApiError) as e:
            c.backbones(["nothere"])
        assert e.value.status == 404
        with pytest.raises(ApiError) as e:
            c.backbones(names[:1], modal_mass_kg=-1.0)
        assert e.value.status == 422
        with pytest.raises(ApiError) as e:          # bad input: named, without the server's paths
            c.backbones([n for n in names if "ringdown" in n], sensor="nothere")
        assert e.value.status == 422 and "nothere" in e.value.message and str(d) not in e.value.message


@pytest.mark.slow
def test_backbones_stored_under_a_name_and_read_back(served):
    url, d = served
    names = [Path(f).stem for f in sorted(glob.glob(str(d / "*.h5")))]
    with Client(url, CONTROL) as c:
        got = c.backbones(names, save_as="pr")
        assert got["saved"] == "pr" and (d / "backbones" / "pr.json").is_file()
        assert c.stored_backbones() == ["pr"]
        f = c.stored_backbone("pr")
        assert f["format"] == "labjoint.backbone/1" and f["mode"] == 1
        stored = [p["frequency_hz"] for b in f["backbones"] for p in b["points"]]
        assert stored == pytest.approx([p["frequency_hz"] for p in got["points"]])
        with pytest.raises(ApiError) as e:          # never overwritten unless asked
            c.backbones(names, save_as="pr")
        assert e.value.status == 422 and "overwrite" in e.value.message
        assert c.backbones(names, save_as="pr", overwrite=True)["saved"] == "pr"
        with pytest.raises(ApiError) as e:
            c.backbones(names, save_as="jobs")
        assert e.value.status == 422
