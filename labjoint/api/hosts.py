"""Refuse requests whose Host header names another server (DNS rebinding: a web page that
makes its own name resolve to 127.0.0.1 must not reach the rig through the user's
browser). The names allowed are :meth:`ApiSettings.host_names`; ``[api] allowed_hosts``
sets them when the service is reached by other names."""

from __future__ import annotations

import json
from typing import Any


def _name(host: str) -> str:
    host = host.strip().lower()
    if host.startswith("["):                     # [::1]:8000
        return host[1:host.find("]")] if "]" in host else host
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


class HostCheck:
    """ASGI middleware: 400 with the API's JSON error body for an unknown Host."""

    def __init__(self, app: Any, names: set[str]) -> None:
        self.app, self.names = app, names

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] in ("http", "websocket"):
            host = dict(scope.get("headers") or []).get(b"host", b"").decode("latin-1")
            if _name(host) not in self.names:
                body = json.dumps({"error": {
                    "code": "bad_host", "message": f"unknown Host {host!r}: this service answers "
                    f"to {sorted(self.names)} (set [api] allowed_hosts)", "details": None}}).encode()
                if scope["type"] == "http":
                    await send({"type": "http.response.start", "status": 400,
                                "headers": [(b"content-type", b"application/json"),
                                            (b"content-length", str(len(body)).encode())]})
                    await send({"type": "http.response.body", "body": body})
                return
        await self.app(scope, receive, send)
