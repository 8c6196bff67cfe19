"""Requests refused for what they are (issue 17 item 1): impossible dates in run filters
are 422, and an analysis of runs that do not exist is 404 before its options are read."""

from __future__ import annotations

import pytest

from labjoint.api import ApiSettings, create_app
from test_api_helpers import AUTH, CONTROL, live_server
from patience import http_client


@pytest.fixture(scope="module")
def http(tmp_path_factory):
    app = create_app(ApiSettings(data_dir=tmp_path_factory.mktemp("req"), control_tokens=[CONTROL]))
    with live_server(app) as url, http_client(url + "/api/v1", headers=AUTH) as client:
        yield client


@pytest.mark.parametrize("since", ["2026-02-30", "2026-13-01", "2026-01-01T25:00", "2026-04-31"])
def test_impossible_dates_in_run_filters_are_refused(http, since):
    r = http.get("/runs", params={"since": since})
    assert r.status_code == 422, r.text
    assert "since" in r.text
    assert http.get("/runs", params={"until": since}).status_code == 422


def test_real_dates_filter(http):
    assert http.get("/runs", params={"since": "2024-02-29", "until": "2026-11-25T10:00:00Z"}).status_code == 200


def test_an_analysis_of_missing_runs_is_404_before_its_options_are_judged(http):
    r = http.post("/analyses", json={"runs": ["no_such_run"], "method": "stick_slip",
                                     "options": {"mu": -3}})
    assert r.status_code == 404, r.text
    assert "no_such_run" in r.text
