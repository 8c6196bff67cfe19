"""Serve the dashboard from package files: ``/`` (the page), ``/static/...`` (its scripts
and styles, from memory: :mod:`labjoint.web.assets`) and ``/web/effects.json`` (the
effect vocabulary the model editor offers).

Everything the page needs ships in ``labjoint/web/static`` (no CDN, no build step), and a
Content-Security-Policy of ``'self'`` makes the browser refuse anything from elsewhere.
Only those three paths are taken, so unknown ``/api/...`` paths still get the API's
JSON errors.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse, Response
from starlette.routing import Mount

from labjoint.vocabulary import EFFECTS
from labjoint.web.assets import MemoryAssets

#: Headers of every dashboard response: nothing may load from another origin.
SECURITY_HEADERS = {
    "Content-Security-Policy": ("default-src 'self'; script-src 'self'; style-src 'self'; "
                                "img-src 'self' data:; font-src 'self'; connect-src 'self'; "
                                "object-src 'none'; base-uri 'none'; frame-ancestors 'none'; "
                                "form-action 'self'"),
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-cache",
}

EFFECTS_ROUTE = "web-effects"



def static_dir() -> Path:
    """The dashboard's files inside the installed package."""
    return Path(str(resources.files("labjoint.web").joinpath("static")))


def effects_catalog() -> list[dict[str, Any]]:
    """Every effect of the vocabulary with its kind and parameters (SI units).

    >>> names = [e["name"] for e in effects_catalog()]
    >>> names[:2], "iwan" in names
    (['linear_stiffness', 'viscous'], True)
    """
    return [{"name": e.name, "kind": e.kind,
             "params": [{"name": p.name, "unit": p.unit, "description": p.description}
                        for p in e.params]}
            for e in EFFECTS.values()]


def mount_web(app: FastAPI) -> bool:
    """Add the dashboard to ``app``: ``GET /``, ``/static/*`` and ``GET /web/effects.json``.

    Returns False (and adds nothing) when the package has no ``static/index.html``.
    Call it after the API's routers are included. Idempotent; a plain static mount of
    the dashboard at ``/`` (named "web") added earlier is replaced, so unknown paths
    keep the API's JSON 404.
    """
    root = static_dir()
    index = root / "index.html"
    if not index.is_file():
        return False
    if any(getattr(r, "name", None) == EFFECTS_ROUTE for r in app.router.routes):
        return True
    app.router.routes[:] = [r for r in app.router.routes
                            if not (isinstance(r, Mount) and r.path == "" and r.name == "web")]

    assets = MemoryAssets(root, SECURITY_HEADERS)   # from memory, gzipped once, ETags

    @app.get("/", include_in_schema=False)
    async def dashboard(request: Request) -> Response:
        page = assets.asset("index.html")
        if page is None:
            return JSONResponse({"detail": "the dashboard page is missing"}, status_code=404)
        return assets.response(page, request.headers)

    @app.get("/web/effects.json", include_in_schema=False, name=EFFECTS_ROUTE)
    def effects() -> JSONResponse:
        return JSONResponse(effects_catalog(), headers=SECURITY_HEADERS)

    app.mount("/static", assets, name="web-static")
    return True
