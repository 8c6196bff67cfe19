"""The FastAPI application: routers under ``/api/v1``, OpenAPI at ``/openapi.json``.

``create_app`` wires the settings, the run catalog of ``data_dir``, the job runner for
analyses and models, and (optionally) the acquisition daemon and its job queue. ``/``
is left to the web dashboard: :func:`mount_web` serves ``labjoint/web/static`` there
once it exists.
"""

from __future__ import annotations

import logging
from contextlib import asynccontextmanager
from importlib import resources
from typing import Any, AsyncIterator

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from fastapi.staticfiles import StaticFiles
from starlette.middleware.gzip import DEFAULT_EXCLUDED_CONTENT_TYPES, GZipMiddleware
from starlette.routing import compile_path

from labjoint import __version__
from labjoint.api.docs import install_docs
from labjoint.api.errors import install_error_handlers
from labjoint.api.fastpath import RunSummaryFastPath
from labjoint.api.hosts import HostCheck, OriginCheck
from labjoint.api.jobs import JobRunner, JobStore
from labjoint.api.limits import BodySizeLimit
from labjoint.api.resolve import RunResolver
from labjoint.api.routes import (analyses, backbones, models, plans, reprocess, runs, structures,
                                 system, trends)
from labjoint.api.routes import spectra
from labjoint.api.settings import ApiSettings
from labjoint.storage import open_catalog

log = logging.getLogger(__name__)
API_PREFIX = "/api/v1"
JOBS_FILE = "api_jobs.sqlite"
#: Responses smaller than this go out as they are (gzip's header would outweigh the gain).
GZIP_MIN_BYTES = 500
#: Level 6: most of level 9's ratio on JSON and scripts at a fraction of its CPU time.
GZIP_LEVEL = 6
#: Run files are HDF5 (already chunk-compressed where it pays): sent as stored.
NOT_GZIPPED = DEFAULT_EXCLUDED_CONTENT_TYPES + ("application/x-hdf5", "application/octet-stream")


def create_app(settings: ApiSettings, daemon: Any = None, queue: Any = None,
               backend: str | None = None) -> FastAPI:
    """The REST service over ``settings.data_dir``.

    ``daemon``: an in-process acquisition daemon (status, emergency stop); ``queue``:
    the daemon's job queue (plans). Either may be None: the matching endpoints then
    answer 503. ``backend`` ("sim"/"real") is shown in the rig status.
    """
    data_dir = settings.data_dir
    data_dir.mkdir(parents=True, exist_ok=True)
    jobs = JobRunner(JobStore(data_dir / JOBS_FILE), workers=settings.analysis_workers)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        yield
        for hook in app.state.shutdown_hooks:   # e.g. stop an embedded daemon
            try:
                hook()
            except Exception:
                log.exception("shutdown hook %r failed", hook)
        jobs.shutdown(wait=False)

    app = FastAPI(title="labjoint", version=__version__, lifespan=lifespan,
                  description="Bolted-joint dynamics lab: plans on the shaker rig, run files, "
                              "identification and model comparison. SI units throughout.",
                  openapi_url="/openapi.json", docs_url=None, redoc_url=None)
    install_docs(app)
    catalog = open_catalog(data_dir, settings.catalog_url)
    st = app.state
    st.settings, st.catalog, st.jobs = settings, catalog, jobs
    st.resolver = RunResolver(data_dir, catalog)
    st.daemon, st.queue, st.backend = daemon, queue, backend
    st.shutdown_hooks = []  # callables run when the server shuts down

    install_error_handlers(app)
    # innermost: the run summary answered before the router (every check below applies)
    app.add_middleware(RunSummaryFastPath, state=st, prefix=API_PREFIX)
    # scripts, styles and JSON compressed for clients that accept gzip (issue 17 item 12)
    app.add_middleware(GZipMiddleware, minimum_size=GZIP_MIN_BYTES, compresslevel=GZIP_LEVEL,
                       exclude_content_types=NOT_GZIPPED)
    app.add_middleware(BodySizeLimit, max_bytes=settings.max_request_bytes)
    app.add_middleware(OriginCheck, allowed=settings.allowed_origins)
    app.add_middleware(HostCheck, names=settings.host_names())
    table = [(r.path_regex, set(r.methods)) for r in app.routes
             if getattr(r, "methods", None) and hasattr(r, "path_regex")]
    for module in (system, plans, runs, analyses, models, structures, trends, reprocess, backbones,
                   spectra):
        app.include_router(module.router, prefix=API_PREFIX)
        table += [(compile_path(API_PREFIX + r.path)[0], set(r.methods))
                  for r in module.router.routes if getattr(r, "methods", None)]
    st.route_table = table  # path regex -> methods, for 405 answers with a full Allow
    app.openapi = lambda: _openapi(app)  # type: ignore[method-assign]
    mount_web(app)
    return app


def _openapi(app: FastAPI) -> dict[str, Any]:
    """The schema, with each operation's security as enforced: writes (every non-GET)
    need a token; reads only when ``read_requires_token``; health never."""
    if app.openapi_schema is None:
        schema = get_openapi(title=app.title, version=app.version, description=app.description,
                             routes=app.routes)
        reads_open = not app.state.settings.read_requires_token
        for path, ops in schema.get("paths", {}).items():
            for method, op in ops.items():
                if method == "get" and (reads_open or path.endswith("/health")):
                    op.pop("security", None)
        app.openapi_schema = schema
    return app.openapi_schema


def mount_web(app: FastAPI) -> bool:
    """Serve the web dashboard at ``/`` when ``labjoint/web/static/index.html`` exists: by
    :func:`labjoint.web.mount.mount_web` (page, its files, security headers), or as plain
    static files if that module is missing. A no-op without the page; True when mounted.
    """
    try:
        from labjoint.web.mount import mount_web as mount_dashboard
    except ImportError:
        mount_dashboard = None
    if mount_dashboard is not None:
        return bool(mount_dashboard(app))
    static = resources.files("labjoint").joinpath("web", "static")
    if not (static.is_dir() and static.joinpath("index.html").is_file()):
        return False
    app.mount("/", StaticFiles(directory=str(static), html=True), name="web")
    return True
