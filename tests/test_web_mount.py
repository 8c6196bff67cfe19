"""The dashboard as served: page, scripts and styles from the package with a same-origin
CSP, nothing fetched from elsewhere, every ES-module import resolvable, API 404s intact."""

from __future__ import annotations

import re

import pytest
from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles
from starlette.routing import Mount

from labjoint.api import ApiSettings, create_app
from labjoint.vocabulary import EFFECTS
from labjoint.web.mount import mount_web, static_dir
from test_api_helpers import live_server
from patience import http_client

STATIC = static_dir()
IMPORT = re.compile(r"""^\s*import\s[^'"]*['"]([^'"]+)['"]""", re.M)
URL = re.compile(r"""(?:https?:)?//[a-z0-9.-]+\.[a-z]{2,}""", re.I)
SVG_NS = "http://www.w3.org/2000/svg"


@pytest.fixture()
def client(tmp_path):
    app = create_app(ApiSettings(data_dir=tmp_path / "data"))   # mounts the dashboard itself
    with live_server(app) as url, http_client(url) as c:
        yield c


def test_page_and_assets_are_served_same_origin_only(client):
    r = client.get("/")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    csp = r.headers["content-security-policy"]
    assert "default-src 'self'" in csp and "script-src 'self'" in csp
    assert r.headers["x-content-type-options"] == "nosniff"
    for src in re.findall(r'(?:src|href)="(/static/[^"]+)"', r.text):
        asset = client.get(src)
        assert asset.status_code == 200, src
        assert "content-security-policy" in asset.headers
    js = client.get("/static/js/main.js")
    assert js.headers["content-type"].split(";")[0] == "text/javascript"


def test_unknown_api_paths_keep_json_errors(client):
    r = client.get("/api/v1/no-such-thing")
    assert r.status_code == 404
    assert r.headers["content-type"].startswith("application/json")
    assert client.get("/static/js/nope.js").status_code == 404


def test_effect_catalog_is_the_vocabulary(client):
    effects = client.get("/web/effects.json").json()
    assert [e["name"] for e in effects] == list(EFFECTS)
    iwan = next(e for e in effects if e["name"] == "iwan")
    assert [p["name"] for p in iwan["params"]] == [p.name for p in EFFECTS["iwan"].params]


def test_mount_is_idempotent_and_replaces_a_plain_root_mount():
    app = FastAPI()
    app.mount("/", StaticFiles(directory=str(STATIC), html=True), name="web")
    assert mount_web(app)
    n = len(app.router.routes)
    assert mount_web(app) and len(app.router.routes) == n
    assert not any(isinstance(r, Mount) and r.path == "" for r in app.router.routes)
    assert {"/", "/web/effects.json", "/static"} <= {getattr(r, "path", None) for r in app.router.routes}


def test_no_file_refers_to_another_origin():
    files = [p for p in STATIC.rglob("*") if p.is_file()]
    assert any(p.suffix == ".js" for p in files) and any(p.suffix == ".css" for p in files)
    for p in files:
        text = p.read_text().replace(SVG_NS, "")
        assert not URL.findall(text), f"{p.relative_to(STATIC)} refers to {URL.findall(text)}"
        assert "@import" not in text and "@font-face" not in text, p


def test_every_module_import_resolves_to_a_shipped_file():
    modules = list((STATIC / "js").rglob("*.js"))
    assert len(modules) >= 10
    for m in modules:
        for spec in IMPORT.findall(m.read_text()):
            assert spec.startswith("."), f"{m.name} imports a bare specifier {spec!r}"
            assert (m.parent / spec).resolve().is_file(), f"{m.name}: {spec} is missing"


def _closure(module, seen=None):
    """``module`` (a path under static/js) and every module it imports, in import order."""
    seen = [] if seen is None else seen
    if module not in seen:
        seen.append(module)
        path = STATIC / "js" / module
        for spec in IMPORT.findall(path.read_text()):
            _closure((path.parent / spec).resolve().relative_to(STATIC / "js").as_posix(), seen)
    return seen


def test_each_view_preloads_exactly_the_modules_it_imports():
    """main.js loads a view's modules when the view is shown, all of them preloaded at
    once: each list must be the view's import closure (a module missing from it would
    be fetched one import level later; an extra one fetched for nothing)."""
    main = (STATIC / "js" / "main.js").read_text()
    table = main[main.index("export const VIEWS = {"):]
    table = table[:table.index("};")]
    views = {name: re.findall(r"'([^']+)'", files)
             for name, files in re.findall(r"(\w+): \[([^\]]*)\]", table)}
    shipped_views = {m.stem for m in (STATIC / "js" / "views").glob("*.js")}
    nav = set(re.findall(r'data-view="(\w+)"', (STATIC / "index.html").read_text()))
    assert set(views) == nav | {"run"} and set(views) <= shipped_views   # every page, and a run's
    static_imports = set(_closure("main.js")) - {"main.js"}
    for name, files in views.items():
        assert files[0] == f"views/{name}.js"
        assert set(files) == set(_closure(files[0])) - static_imports, name
        assert len(files) == len(set(files)), name
    html = (STATIC / "index.html").read_text()
    preloaded = set(re.findall(r'rel="modulepreload" href="/static/js/([^"]+)"', html))
    # the page itself preloads main.js's imports and the first page's (the runs list)
    assert static_imports == {"api.js"}
    assert preloaded == static_imports | set(views["runs"])
    every = {m.relative_to(STATIC / "js").as_posix() for m in (STATIC / "js").rglob("*.js")}
    assert every == {"main.js"} | static_imports | {f for fs in views.values() for f in fs}


def test_scripts_styles_and_json_are_gzipped_for_clients_that_accept_it(client):
    """Issue 17 item 12: compressed when asked (and much smaller), identical once
    decoded, plain for a client that does not accept gzip."""
    import gzip
    for path, kind in (("/static/js/views/models.js", "text/javascript"),
                       ("/static/css/app.css", "text/css"), ("/", "text/html"),
                       ("/web/effects.json", "application/json"),
                       ("/openapi.json", "application/json")):
        plain = client.get(path, headers={"Accept-Encoding": "identity"})
        assert plain.status_code == 200 and "content-encoding" not in plain.headers, path
        raw = client.stream("GET", path, headers={"Accept-Encoding": "gzip"})
        with raw as r:
            body = b"".join(r.iter_raw())          # the bytes on the wire
            assert r.headers.get("content-encoding") == "gzip", path
            assert r.headers["content-type"].startswith(kind), path
            assert "Accept-Encoding" in r.headers.get("vary", ""), path
        assert gzip.decompress(body) == plain.content, path
        assert len(body) < 0.6 * len(plain.content), (path, len(body), len(plain.content))
