"""The API's hottest read, ``GET /api/v1/runs/{name}``, answered before the router.

A lab's page asks for run summaries by the hundred. Through FastAPI each one costs the
route table's regex scan and the dependency solver, several times the catalog lookup
itself (issue 31: p99 <= 10 ms with 20 clients). :class:`RunSummaryFastPath` is an ASGI
middleware placed innermost (inside the Host, Origin, size and gzip checks, which still
apply) that answers this one request the way the route does, with the same body
(:func:`summary_body`, which the route also uses) and only when the route would answer
200: reads open, or a known token sent. Anything else (a malformed or unknown name, a
missing or unknown token, HEAD, other paths) goes on to the router unchanged, so errors
keep their one source.

Bodies are cached, pre-serialised, per catalog version (:class:`SummaryCache`): a
SQLite catalog's ``PRAGMA data_version`` changes whenever another connection commits,
so a run written, re-catalogued or removed by any process is seen on the next request.
A PostgreSQL catalog has no such cheap counter: its bodies are built per request.
"""

from __future__ import annotations

import re
from typing import Any

import orjson
from fastapi.security.utils import get_authorization_scheme_param

from labjoint.api.errors import ApiError
from labjoint.api.jobs import json_safe
from labjoint.api.resolve import RunResolver
from labjoint.api.schemas import RunSummary
from labjoint.storage import RunRecord

#: Bodies kept at most (a run summary is about 1 kB): the catalog's hot set.
CACHE_RUNS = 20_000
_FIELDS = tuple(k for k in RunSummary.model_fields if k != "metadata")


def summary(rec: RunRecord) -> dict[str, Any]:
    """A catalog record as the API shows it (the server's file path left out)."""
    d = {k: getattr(rec, k) for k in _FIELDS}
    d["metadata"] = rec.metadata
    return json_safe(d)


class SummaryCache:
    """Serialised run summaries of one catalog, dropped whenever the catalog changes."""

    def __init__(self, resolver: RunResolver, size: int = CACHE_RUNS) -> None:
        self.resolver, self.size = resolver, size
        self.bodies: dict[str, bytes] = {}
        self.version: Any = None

    def _version(self) -> Any:
        """The catalog's change counter as seen by this thread's reader connection, or
        None when there is none (PostgreSQL: no caching)."""
        sql = self.resolver.catalog.sql
        if sql.dialect != "sqlite":
            return None
        with sql.reader() as s:
            return id(s.con), s.con.execute("PRAGMA data_version").fetchone()[0]

    def body(self, name: str) -> bytes:
        """The JSON body of ``name``'s summary (ApiError as :meth:`RunResolver.record`)."""
        version = self._version()
        if version is None:
            return orjson.dumps(summary(self.resolver.record(name)))
        if version != self.version:
            self.bodies.clear()
            self.version = version
        body = self.bodies.get(name)
        if body is None:
            body = orjson.dumps(summary(self.resolver.record(name)))
            if len(self.bodies) >= self.size:
                self.bodies.clear()
            self.bodies[name] = body
        return body


def summary_body(state: Any, name: str) -> bytes:
    """``name``'s summary as JSON bytes, from the app's cache (made on first use)."""
    cache = getattr(state, "summary_cache", None)
    if cache is None or cache.resolver is not state.resolver:
        cache = state.summary_cache = SummaryCache(state.resolver)
    return cache.body(name)


JSON_HEADERS = [(b"content-type", b"application/json")]


class RunSummaryFastPath:
    """ASGI middleware: ``GET {prefix}/runs/{name}`` answered from :func:`summary_body`
    when the route would answer it with 200; every other request goes to ``app``."""

    def __init__(self, app: Any, state: Any, prefix: str) -> None:
        self.app, self.state = app, state
        self.pattern = re.compile(re.escape(prefix) + r"/runs/([^/]+)")

    def _may_read(self, scope: dict[str, Any]) -> bool:
        """As :func:`labjoint.api.auth.require_read`: reads open, or a known token."""
        settings = self.state.settings
        auth = None
        for key, value in scope.get("headers") or ():
            if key == b"authorization":
                auth = value.decode("latin-1")
                break
        if not auth:
            return not settings.read_requires_token
        scheme, token = get_authorization_scheme_param(auth)
        return scheme.lower() == "bearer" and bool(token) and \
            settings.scope_of(token) is not None

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] == "http" and scope["method"] == "GET":
            m = self.pattern.fullmatch(scope["path"])
            if m is not None and self._may_read(scope):
                try:
                    body = summary_body(self.state, m[1])
                except ApiError:
                    pass                # the route answers it, with its own error body
                else:
                    await send({"type": "http.response.start", "status": 200,
                                "headers": JSON_HEADERS + [
                                    (b"content-length", str(len(body)).encode())]})
                    await send({"type": "http.response.body", "body": body})
                    return
        await self.app(scope, receive, send)
