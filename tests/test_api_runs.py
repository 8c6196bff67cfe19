"""Runs endpoints through a real uvicorn: catalog filters and pages, metadata, the HDF5
file, data slices in physical units, min/max decimation, and path-traversal refusals."""

from __future__ import annotations

import os

import numpy as np
import pytest

from labjoint.api import ApiSettings, create_app
from labjoint.storage import Catalog
from test_api_helpers import (AUTH, CONTROL, DISP_M_PER_V, NC_N_PER_V, READ, linear_joint,
                              live_server, write_linear_run)
from patience import http_client

FS, F, AMP, K, C, N = 20000.0, 100.0, 5e-6, 1e7, 500.0, 8000
VPPS = (1.0, 4.0, 8.0, 12.0, 16.0)


@pytest.fixture(scope="module", params=["sqlite", "postgresql"])
def served(tmp_path_factory, request):
    """The service over a data directory whose catalog is the embedded SQLite file, or a
    PostgreSQL database (``catalog_url``)."""
    d = tmp_path_factory.mktemp("data")
    url = ("" if request.param == "sqlite" else
           request.getfixturevalue("pg_server_instance").new_database())
    cat = Catalog(url or d / "catalog.sqlite")
    for i, vpp in enumerate(VPPS):
        write_linear_run(d, cat, f"sweep_{i:02d}", vpp=vpp, torque_nm=5.0 if i < 4 else 8.0,
                         fs=FS, f=F, amp_m=AMP, k=K, c=C, n=N)
    app = create_app(ApiSettings(data_dir=d, control_tokens=[CONTROL], read_tokens=[READ],
                                 catalog_url=url))
    assert (d / "catalog.sqlite").exists() == (not url)
    with live_server(app) as url, http_client(url + "/api/v1") as http:
        yield http, d, cat


def test_filters_select_by_excitation_and_torque(served):
    http, _, _ = served
    body = http.get("/runs", params={"vpp_min": 3, "vpp_max": 12.5, "torque_nm": 5}).json()
    assert sorted(r["name"] for r in body["items"]) == ["sweep_01", "sweep_02", "sweep_03"]
    assert all(3 <= r["excitation_vpp"] <= 12.5 and r["torque_nm"] == 5 for r in body["items"])
    eight = http.get("/runs", params={"torque_nm": 8}).json()["items"]
    assert [r["name"] for r in eight] == ["sweep_04"]
    assert eight[0]["normal_force_n"] == pytest.approx(478.0 * 8)   # seed 002 ratio


def test_pages_cover_every_run_once_in_order(served):
    http, _, _ = served
    names, offset = [], 0
    while offset is not None:
        page = http.get("/runs", params={"limit": 2, "offset": offset,
                                         "order": "-excitation_vpp"}).json()
        assert len(page["items"]) <= 2
        names += [r["name"] for r in page["items"]]
        offset = page["next_offset"]
    assert names == [f"sweep_{i:02d}" for i in reversed(range(len(VPPS)))]


def test_search_by_part_of_the_name_and_total_over_every_page(served):
    """The run pickers page through a big catalog: a name search (case-insensitive,
    wildcards taken literally) and the count of every match."""
    http, _, _ = served
    page = http.get("/runs", params={"search": "EEP_0", "limit": 2, "vpp_min": 3}).json()
    assert page["total"] == 4 and len(page["items"]) == 2 and page["next_offset"] == 2
    assert all("sweep_0" in r["name"] for r in page["items"])
    assert http.get("/runs", params={"search": "sweep_03"}).json()["total"] == 1
    assert http.get("/runs", params={"search": "%"}).json()["total"] == 0   # no wildcard
    assert http.get("/runs", params={"search": "_0"}).json()["total"] == len(VPPS)


def test_run_metadata_and_errors(served):
    http, _, _ = served
    r = http.get("/runs/sweep_02").json()
    assert (r["frequency_hz"], r["excitation_vpp"]) == (F, 8.0)
    assert (r["n_samples"], r["status"]) == (N, "complete")
    assert "path" not in r                      # server paths are not shown
    missing = http.get("/runs/nope")
    assert missing.status_code == 404 and missing.json()["error"]["code"] == "not_found"
    bad = http.get("/runs/.hidden")
    assert bad.status_code == 422 and set(bad.json()["error"]) == {"code", "message", "details"}


def test_channels_report_calibration(served):
    http, _, _ = served
    body = http.get("/runs/sweep_00/channels").json()
    by = {c["name"]: c for c in body["channels"]}
    assert by["disp_1"]["units_per_volt"] == DISP_M_PER_V
    assert by["shear_nc"]["units_per_volt"] == NC_N_PER_V
    assert body["derived"]["displacement"] == ["disp_1", "disp_2"]
    assert body["duration_s"] == pytest.approx(N / FS)


def test_slice_in_physical_units_matches_the_written_motion(served):
    http, _, _ = served
    body = http.get("/runs/sweep_01/data", params={
        "channel": ["displacement", "force", "disp_1"], "start": 0.1, "stop": 0.15,
        "max_points": 5000}).json()
    assert (body["start_sample"], body["stop_sample"]) == (2000, 3000)
    assert body["decimated"] is False
    s = {x["name"]: x for x in body["series"]}
    t = np.array(s["displacement"]["time_s"])
    assert t[0] == pytest.approx(0.1) and t.size == 1000
    _, u, force = linear_joint(N, FS, F, AMP, K, C)
    np.testing.assert_allclose(s["displacement"]["values"], u[2000:3000], atol=1e-6 * AMP)
    np.testing.assert_allclose(s["force"]["values"], force[2000:3000], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(s["disp_1"]["values"], u[2000:3000] / 2, atol=1e-6 * AMP)
    assert (s["displacement"]["unit"], s["force"]["unit"]) == ("m", "N")


def test_slice_in_samples_and_clipped_to_the_run(served):
    http, _, _ = served
    body = http.get("/runs/sweep_00/data", params={"channel": "disp_2", "start": 7990,
                                                   "stop": 10**7, "unit": "samples"}).json()
    assert (body["start_sample"], body["stop_sample"]) == (7990, N)
    assert len(body["series"][0]["values"]) == 10
    empty = http.get("/runs/sweep_00/data", params={"start": 5, "stop": 1}).json()
    assert all(len(x["values"]) == 0 for x in empty["series"])


def test_decimation_keeps_every_peak_within_max_points(served):
    http, _, _ = served
    body = http.get("/runs/sweep_03/data", params={"channel": "force", "max_points": 100}).json()
    s = body["series"][0]
    v, t = np.array(s["values"]), np.array(s["time_s"])
    assert body["decimated"] and len(v) <= 100
    _, _, force = linear_joint(N, FS, F, AMP, K, C)
    assert v.max() == pytest.approx(force.max()) and v.min() == pytest.approx(force.min())
    assert np.all(np.diff(t) > 0)
    # every returned point is a true sample at its own time
    np.testing.assert_allclose(v, force[np.rint(t * FS).astype(int)], rtol=1e-9, atol=1e-9)


def test_unknown_channel_is_404(served):
    http, _, _ = served
    r = http.get("/runs/sweep_00/data", params={"channel": "nope"})
    assert r.status_code == 404 and "disp_1" in r.json()["error"]["message"]


def test_download_is_the_stored_file(served):
    http, d, _ = served
    r = http.get("/runs/sweep_04/file")
    assert r.status_code == 200 and r.headers["content-type"] == "application/x-hdf5"
    assert r.content == (d / "sweep_04.h5").read_bytes()
    assert "sweep_04.h5" in r.headers["content-disposition"]


@pytest.mark.parametrize("path", ["/runs/..%2F..%2Fetc%2Fpasswd/file", "/runs/%2Fetc%2Fpasswd/file",
                                  "/runs/../../../etc/passwd", "/runs/..%252F..%252Fetc/file",
                                  "/runs/sweep_00%00.h5/file"])
def test_path_traversal_in_the_name_is_refused(served, path):
    http, _, _ = served
    r = http.get(path)
    assert r.status_code in (404, 422)
    assert "root:" not in r.text and r.headers["content-type"] == "application/json"


def test_catalog_entry_outside_the_data_dir_is_not_served(served, tmp_path):
    http, d, cat = served
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    p = write_linear_run(outside, Catalog(outside / "c.sqlite"), "stray", n=2000)
    cat.add(p)                                  # catalogued, but outside data_dir
    link = d / "linked.h5"
    os.symlink(p, link)                         # a symlink inside pointing out
    rec = cat.get("stray")
    rec.name = "linked"
    rec.path = str(link)
    cat.put(rec)
    try:
        for name in ("stray", "linked"):
            r = http.get(f"/runs/{name}/file")
            assert r.status_code == 403 and r.json()["error"]["code"] == "outside_data_dir"
            assert http.get(f"/runs/{name}/data").status_code == 403
    finally:
        cat.remove("stray")
        cat.remove("linked")
        link.unlink()


def test_running_run_cannot_be_downloaded_but_can_be_sliced(served):
    http, d, cat = served
    write_linear_run(d, cat, "live_one", n=4000, status="complete")
    rec = cat.get("live_one")
    rec.status = "running"
    cat.put(rec)
    try:
        r = http.post("/runs/live_one/file", headers=AUTH)
        assert r.status_code == 405
        r = http.get("/runs/live_one/file")
        assert r.status_code == 409 and r.json()["error"]["code"] == "run_in_progress"
        assert http.get("/runs/live_one/data", params={"max_points": 10}).status_code == 200
    finally:
        cat.remove("live_one")
