"""Refuse requests from where they must not come.

- :class:`HostCheck`: a Host header naming another server (DNS rebinding: a web page
  that makes its own name resolve to 127.0.0.1 must not reach the rig through the user's
  browser). The names allowed are :meth:`ApiSettings.host_names`; ``[api]
  allowed_hosts`` sets them when the service is reached by other names.
- :class:`OriginCheck`: a state-changing call (any method but GET, HEAD, OPTIONS) sent
  by a web page of another origin. Any page a user opens can make the browser POST to
  ``http://127.0.0.1:8000`` (a "no-cors" fetch or a form: no pre-flight, the answer
  unread, the request still served), and a token-less emergency stop from loopback is
  allowed; browsers name the page's origin in ``Origin`` on every such request (and
  ``Sec-Fetch-Site`` says ``cross-site``), so the service refuses them with 403 unless
  the origin is its own (the host and port the request was sent to, whatever the
  scheme: behind a TLS proxy the page is https) or is listed in ``[api] allowed_origins``. Scripts and the CLI send no ``Origin``: unaffected.
"""

from __future__ import annotations

import json
from typing import Any
from urllib.parse import urlsplit

#: Methods that only read: never refused for their origin.
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})


def _name(host: str) -> str:
    host = host.strip().lower()
    if host.startswith("["):                     # [::1]:8000
        return host[1:host.find("]")] if "]" in host else host
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


async def _refuse(send: Any, status: int, code: str, message: str) -> None:
    body = json.dumps({"error": {"code": code, "message": message, "details": None}}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


class HostCheck:
    """ASGI middleware: 400 with the API's JSON error body for an unknown Host."""

    def __init__(self, app: Any, names: set[str]) -> None:
        self.app, self.names = app, names

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] in ("http", "websocket"):
            host = dict(scope.get("headers") or []).get(b"host", b"").decode("latin-1")
            if _name(host) not in self.names:
                if scope["type"] == "http":
                    await _refuse(send, 400, "bad_host", f"unknown Host {host!r}: this service "
                                  f"answers to {sorted(self.names)} (set [api] allowed_hosts)")
                return
        await self.app(scope, receive, send)


def _origin(url: str) -> str:
    """``scheme://host[:port]`` in lower case (default ports left out)."""
    p = urlsplit(url.strip().lower())
    default = {"http": 80, "https": 443}.get(p.scheme)
    try:
        port = p.port
    except ValueError:
        return url
    host = p.hostname or ""
    host = f"[{host}]" if ":" in host else host
    return f"{p.scheme}://{host}" + ("" if port in (None, default) else f":{port}")


def _netloc(origin: str) -> str:
    """``host[:port]`` of a normalised origin (default ports already left out)."""
    return origin.split("://", 1)[-1]


class OriginCheck:
    """ASGI middleware: 403 for a state-changing request from a foreign web page."""

    def __init__(self, app: Any, allowed: tuple[str, ...] = ()) -> None:
        self.app = app
        self.allowed = {_origin(o) for o in allowed}

    def foreign(self, scope: dict[str, Any]) -> str | None:
        """The foreign origin a request comes from, or None when it may pass."""
        headers = dict(scope.get("headers") or [])
        origin = headers.get(b"origin", b"").decode("latin-1").strip()
        site = headers.get(b"sec-fetch-site", b"").decode("latin-1").strip().lower()
        if not origin:
            # no Origin: not a browser's cross-origin write, unless the browser says so
            return f"a {site} page" if site in ("cross-site", "same-site") else None
        if origin.lower() == "null":
            return "an opaque origin (null: a sandboxed frame, a file or a redirect)"
        host = headers.get(b"host", b"").decode("latin-1").strip()
        # the page's host and port against the Host it sent: the scheme is left out, as a
        # TLS proxy in front (https page, http hop to this service) changes only that
        own = _netloc(_origin(f"{scope.get('scheme', 'http')}://{host}"))
        mine = _origin(origin)
        return None if _netloc(mine) == own or mine in self.allowed else origin

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] == "http" and scope.get("method", "GET").upper() not in SAFE_METHODS:
            who = self.foreign(scope)
            if who is not None:
                await _refuse(send, 403, "foreign_origin",
                              f"refused: this {scope.get('method')} request was sent by a web "
                              f"page of another origin ({who}); the rig is driven only from "
                              "this service's own page, the CLI or scripts (list a trusted page "
                              "in [api] allowed_origins)")
                return
        await self.app(scope, receive, send)
