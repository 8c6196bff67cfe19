"""Schemathesis against the published OpenAPI schema, through a real uvicorn: no 500,
every response matches its schema (status codes, content types, bodies), auth enforced
where declared. Plans are queued (no daemon runs them).

``positive_data_acceptance`` is left out: plan parameters and analysis options are free
mappings checked by the plan and pipeline code, so a schema-valid body may rightly get
422 naming the bad parameter.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import httpx
import pytest
import schemathesis
from hypothesis import HealthCheck, settings
from schemathesis.specs.openapi.checks import positive_data_acceptance

from labjoint.api import ApiSettings, create_app
from labjoint.daemon import JobQueue
from labjoint.storage import Catalog
from test_api_helpers import AUTH, CONTROL, READ, live_server, write_linear_run
import patience


def _settings(data_dir: Path) -> ApiSettings:
    return ApiSettings(data_dir=data_dir, control_tokens=[CONTROL], read_tokens=[READ],
                       max_points=500)


def _published_schema() -> dict:
    """The schema as the service publishes it (the app is only built, not served)."""
    with tempfile.TemporaryDirectory() as d:
        return create_app(_settings(Path(d))).openapi()


schema = schemathesis.openapi.from_dict(_published_schema())


@pytest.fixture(scope="module")
def base_url(tmp_path_factory):
    d = tmp_path_factory.mktemp("schema")
    cat = Catalog(d / "catalog.sqlite")
    for name in ("a1", "b2"):
        write_linear_run(d, cat, name, n=4000)
    app = create_app(_settings(d), queue=JobQueue(d / "queue.sqlite"))
    with live_server(app) as url:
        assert httpx.get(url + "/openapi.json", timeout=patience.HTTP_TIMEOUT_S).json() == _published_schema()
        yield url


# schemathesis's own strategies draw from the `random` module, which Hypothesis flags
# now and then (HypothesisDeprecationWarning, turned into a FlakyFailure by the suite's
# warnings-as-errors): a warning about the test library, not about labjoint's API
@pytest.mark.filterwarnings(
    "ignore:Do not use the `random` module inside strategies:hypothesis.errors.HypothesisDeprecationWarning")
@schema.parametrize()
@settings(max_examples=20, deadline=None, database=None,
          suppress_health_check=list(HealthCheck))
def test_api_conforms_to_its_schema(case, base_url):
    kwargs = {"timeout": patience.HTTP_TIMEOUT_S}   # requests' 10 s timed out under load
    response = case.call(base_url=base_url, headers=AUTH, **kwargs)
    if _refused_by_http_parser(response):
        # the drawn request is not valid HTTP/1.1 (uvicorn's parser answers 400 text/plain
        # before the app sees it): the API's schema does not apply, and nothing was served
        assert response.status_code == 400
        return
    case.validate_response(response, excluded_checks=[positive_data_acceptance],
                           transport_kwargs={"base_url": base_url, "headers": dict(AUTH), **kwargs})
    assert response.status_code < 500


def _refused_by_http_parser(response) -> bool:
    """True for uvicorn's protocol-level refusal of a malformed request (h11 or httptools:
    a 400 with the fixed text/plain body), which never reaches labjoint's routes."""
    ctype = response.headers.get("content-type") or [""]     # schemathesis: a list per header
    ctype = ctype[0] if isinstance(ctype, list) else ctype
    return (response.status_code == 400 and ctype.startswith("text/plain")
            and response.text.startswith("Invalid HTTP request received"))
