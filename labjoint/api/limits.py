"""Request size limit: a body over ``max_bytes`` is refused with 413 before it is parsed.

Checks the declared Content-Length up front and counts the bytes of streamed
(chunked) bodies as they arrive, so neither kind can exhaust memory.
"""

from __future__ import annotations

from typing import Any, Awaitable, Callable

from starlette.exceptions import HTTPException

from labjoint.api.errors import error_response

Scope = dict[str, Any]
Message = dict[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]


class BodySizeLimit:
    """ASGI middleware refusing request bodies larger than ``max_bytes`` (413)."""

    def __init__(self, app: Any, max_bytes: int) -> None:
        self.app, self.max_bytes = app, int(max_bytes)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        for key, value in scope.get("headers", []):
            if key == b"content-length":
                try:
                    declared = int(value)
                except ValueError:
                    await self._refuse(scope, receive, send, 400, "bad_request",
                                       "Content-Length is not an integer")
                    return
                if declared > self.max_bytes:
                    await self._refuse(scope, receive, send, 413, "request_too_large",
                                       f"request body of {declared} bytes exceeds the limit of "
                                       f"{self.max_bytes} bytes")
                    return
        seen = 0

        async def counted() -> Message:
            # raised as an HTTPException so FastAPI's body parsing passes it on unchanged
            nonlocal seen
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > self.max_bytes:
                    raise HTTPException(413, f"request body exceeds the limit of "
                                             f"{self.max_bytes} bytes")
            return msg

        await self.app(scope, counted, send)

    async def _refuse(self, scope: Scope, receive: Receive | None, send: Send, status: int,
                      code: str, message: str) -> None:
        response = error_response(status, code, message, headers={"Connection": "close"})
        await response(scope, receive, send)
