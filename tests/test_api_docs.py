"""/docs and /redoc work offline: every script and style they load comes from this
service (issue 17 item 5)."""

import re

import httpx

from labjoint.api import ApiSettings, create_app
from test_api_helpers import live_server
import patience


def test_the_api_docs_load_nothing_from_another_origin(tmp_path):
    app = create_app(ApiSettings(data_dir=tmp_path))
    with live_server(app) as url:
        for page in ("/docs", "/redoc"):
            html = httpx.get(url + page, timeout=patience.HTTP_TIMEOUT_S).text
            refs = re.findall(r'(?:src|href)\s*=\s*["\']([^"\']+)["\']', html)
            refs += re.findall(r"url:\s*['\"]([^'\"]+)['\"]", html)
            assert refs, page
            assert not [r for r in refs if "://" in r or r.startswith("//")], (page, refs)
            for r in refs:
                assert httpx.get(url + r, timeout=patience.HTTP_TIMEOUT_S).status_code == 200, (page, r)
        assert "openapi" in httpx.get(url + "/openapi.json", timeout=patience.HTTP_TIMEOUT_S).json()


def test_a_request_for_another_host_name_is_refused(tmp_path):
    """DNS rebinding: a page whose name resolves to 127.0.0.1 sends its own Host."""
    app = create_app(ApiSettings(data_dir=tmp_path))
    with live_server(app) as url:
        assert httpx.get(url + "/api/v1/health", timeout=patience.HTTP_TIMEOUT_S).status_code == 200
        port = url.rsplit(":", 1)[1]
        assert httpx.get(url + "/api/v1/health", headers={"Host": f"localhost:{port}"}, timeout=patience.HTTP_TIMEOUT_S).status_code == 200
        r = httpx.get(url + "/api/v1/health", headers={"Host": "evil.example:80"}, timeout=patience.HTTP_TIMEOUT_S)
        assert r.status_code == 400 and r.json()["error"]["code"] == "bad_host"
    app = create_app(ApiSettings(data_dir=tmp_path, allowed_hosts=["rig.lab.example"]))
    with live_server(app) as url:
        assert httpx.get(url + "/api/v1/health", headers={"Host": "rig.lab.example"}, timeout=patience.HTTP_TIMEOUT_S).status_code == 200
