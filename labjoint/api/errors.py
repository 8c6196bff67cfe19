"""One JSON error shape for every 4xx/5xx: ``{"error": {"code", "message", "details"}}``.

labjoint's own exceptions map to statuses here, in one place: bad input 422, a job in
the wrong state 409, hardware trouble 503, a tripped safety limit 409. Anything else is
a bug: logged with its traceback and answered 500 without internals.
"""

from __future__ import annotations

import logging
from http import HTTPStatus
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel
from starlette.exceptions import HTTPException as StarletteHTTPException

from labjoint.errors import HardwareError, InputError, LabjointError, LimitExceeded

log = logging.getLogger(__name__)


class ErrorBody(BaseModel):
    code: str
    message: str
    details: Any = None


class ErrorResponse(BaseModel):
    """What every failed request returns."""

    error: ErrorBody


class ApiError(Exception):
    """An error with its HTTP status, machine-readable code and message."""

    def __init__(self, status: int, code: str, message: str, details: Any = None,
                 headers: dict[str, str] | None = None) -> None:
        super().__init__(message)
        self.status, self.code, self.message = status, code, message
        self.details, self.headers = details, headers


def not_found(what: str, name: Any) -> ApiError:
    return ApiError(404, "not_found", f"no {what} {name!r}")


def error_response(status: int, code: str, message: str, details: Any = None,
                   headers: dict[str, str] | None = None) -> JSONResponse:
    body = {"error": {"code": code, "message": message, "details": jsonable_encoder(details)}}
    return JSONResponse(body, status_code=status, headers=headers)


def _status_code_name(status: int) -> str:
    try:
        return HTTPStatus(status).phrase.lower().replace(" ", "_").replace("-", "_")
    except ValueError:
        return "error"


def _validation_details(errors: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for e in errors:
        out.append({"loc": [str(x) for x in e.get("loc", ())], "msg": str(e.get("msg", "")),
                    "type": str(e.get("type", ""))})
    return out


def _queue_errors() -> tuple[tuple[type[BaseException], ...], tuple[type[BaseException], ...]]:
    """(state errors -> 409, not-found errors -> 404) of the daemon's job queue."""
    try:
        from labjoint.daemon.queue import JobNotFound, JobStateError
    except ImportError:
        return (), ()
    return (JobStateError,), (JobNotFound,)


def allowed_methods(request: Request) -> list[str]:
    """Every method some route accepts at the request's path (Starlette names only the
    first matching route's, and FastAPI's included routers may answer 404 instead)."""
    path = request.url.path
    methods: set[str] = set()
    for regex, route_methods in getattr(request.app.state, "route_table", ()):
        if regex.match(path):
            methods |= route_methods
    return sorted(methods)


def install_error_handlers(app: FastAPI) -> None:
    """Route every exception through the one error shape."""
    state_errors, missing_errors = _queue_errors()

    @app.exception_handler(ApiError)
    async def _api(request: Request, exc: ApiError) -> JSONResponse:
        return error_response(exc.status, exc.code, exc.message, exc.details, exc.headers)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        status = exc.status_code
        message = str(exc.detail) if exc.detail else HTTPStatus(status).phrase
        headers = dict(getattr(exc, "headers", None) or {})
        if status in (404, 405) and exc.detail in ("Not Found", "Method Not Allowed"):
            allowed = allowed_methods(request)
            if allowed:
                status = 405
                headers["Allow"] = ", ".join(allowed)
                message = f"{request.method} is not allowed here; allowed: {headers['Allow']}"
            else:
                message = f"no such endpoint: {request.method} {request.url.path}"
        code = "request_too_large" if status == 413 else _status_code_name(status)
        return error_response(status, code, message, headers=headers or None)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, exc: RequestValidationError) -> JSONResponse:
        details = _validation_details(list(exc.errors()))
        first = details[0] if details else {"loc": [], "msg": "invalid request"}
        where = ".".join(first["loc"])
        return error_response(422, "invalid_request", f"{where}: {first['msg']}" if where
                              else first["msg"], details)

    @app.exception_handler(InputError)
    async def _input(request: Request, exc: InputError) -> JSONResponse:
        return error_response(422, "invalid_input", str(exc), {"field": exc.field})

    @app.exception_handler(LimitExceeded)
    async def _limit(request: Request, exc: LimitExceeded) -> JSONResponse:
        return error_response(409, "limit_exceeded", str(exc))

    @app.exception_handler(HardwareError)
    async def _hardware(request: Request, exc: HardwareError) -> JSONResponse:
        return error_response(503, "hardware_error", str(exc))

    async def _state(request: Request, exc: Exception) -> JSONResponse:
        return error_response(409, "conflict", str(exc))

    async def _missing(request: Request, exc: Exception) -> JSONResponse:
        return error_response(404, "not_found", str(exc))

    for cls in state_errors:
        app.add_exception_handler(cls, _state)
    for cls in missing_errors:
        app.add_exception_handler(cls, _missing)

    @app.exception_handler(LabjointError)
    async def _labjoint(request: Request, exc: LabjointError) -> JSONResponse:
        log.exception("unhandled labjoint error on %s %s", request.method, request.url.path)
        return error_response(500, "internal_error", str(exc))

    @app.exception_handler(Exception)
    async def _bug(request: Request, exc: Exception) -> JSONResponse:
        log.exception("internal error on %s %s", request.method, request.url.path)
        return error_response(500, "internal_error",
                              "internal server error (logged on the server)")


#: Error responses documented on every operation (OpenAPI), beside its success status.
COMMON_ERRORS: dict[int | str, dict[str, Any]] = {
    s: {"model": ErrorResponse, "description": d} for s, d in {
        400: "malformed request (body not decodable, bad Content-Length)",
        401: "missing or unknown API token",
        403: "token lacks the scope this endpoint needs",
        404: "no such resource",
        413: "request body too large",
        422: "invalid request or input",
        500: "internal error",
    }.items()
}


def errors_doc(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """COMMON_ERRORS plus the ``statuses`` named (documented with the error shape)."""
    out = dict(COMMON_ERRORS)
    phrases = {409: "conflict with the job's or rig's state", 501: "not implemented yet",
               503: "service unavailable (no daemon or queue, or hardware fault)"}
    for s in statuses:
        out[s] = {"model": ErrorResponse, "description": phrases.get(s, HTTPStatus(s).phrase)}
    return out
