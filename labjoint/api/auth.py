"""API tokens: ``Authorization: Bearer <token>``.

Two scopes. A *control* token may do everything: move hardware (plans, torque,
emergency stop) and write (submit analyses and model fits). A *read* token may only
read, and reads need it only when ``read_requires_token`` is set. A request with no
token gets 401, an unknown token 401, a read token on a control endpoint 403.
"""

from __future__ import annotations

from fastapi import Depends, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from labjoint.api.errors import ApiError
from labjoint.api.settings import ENV_CONTROL, ApiSettings

bearer = HTTPBearer(auto_error=False, scheme_name="bearer",
                    description="API token (control or read), see the [api] config table")
_CHALLENGE = {"WWW-Authenticate": "Bearer"}


def _token(creds: HTTPAuthorizationCredentials | None) -> str | None:
    return creds.credentials if creds is not None else None


def _settings(request: Request) -> ApiSettings:
    return request.app.state.settings


async def require_read(request: Request,
                       creds: HTTPAuthorizationCredentials | None = Depends(bearer)
                       ) -> str | None:
    """Allow a read when reads are open, or a read/control token is given (async: no
    thread-pool hop for a check this cheap)."""
    s = _settings(request)
    token = _token(creds)
    if token is None and not s.read_requires_token:
        return None
    if token is None:
        raise ApiError(401, "unauthorized", "reading needs an API token: send "
                       "'Authorization: Bearer <token>'", headers=_CHALLENGE)
    scope = s.scope_of(token)
    if scope is None:
        raise ApiError(401, "unauthorized", "unknown API token", headers=_CHALLENGE)
    return scope


async def require_control(request: Request,
                          creds: HTTPAuthorizationCredentials | None = Depends(bearer)) -> str:
    """Allow only a control token (hardware and writes)."""
    s = _settings(request)
    token = _token(creds)
    if token is None:
        if not s.control_tokens:
            raise ApiError(403, "forbidden", "no control token is configured on this server "
                           f"(set {ENV_CONTROL} or [api] control_tokens), so nothing may "
                           "move hardware or write")
        raise ApiError(401, "unauthorized", "this endpoint moves hardware or writes: send "
                       "'Authorization: Bearer <control token>'", headers=_CHALLENGE)
    scope = s.scope_of(token)
    if scope is None:
        raise ApiError(401, "unauthorized", "unknown API token", headers=_CHALLENGE)
    if scope != "control":
        raise ApiError(403, "forbidden", "a read-only token cannot move hardware or write")
    return "control"


LOOPBACK = ("127.0.0.1", "::1")


async def require_control_or_loopback(request: Request,
                                      creds: HTTPAuthorizationCredentials | None = Depends(bearer)
                                      ) -> str:
    """The emergency stop's exception: without a token, a request from this machine
    (loopback address) may stop the rig, so a user at the rig never has to type a token
    to stop it; a token, when sent, must still be a control token."""
    if _token(creds) is None and request.client is not None and request.client.host in LOOPBACK:
        return "local"
    return await require_control(request, creds)


def token_label(scope: str | None) -> str:
    """Who submitted a job, as recorded with it (never the token itself)."""
    return f"api:{scope or 'anonymous'}"
