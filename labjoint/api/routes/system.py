"""Health, version, rig and instrument status, emergency stop."""

from __future__ import annotations

import logging
import platform
from typing import Any

from fastapi import APIRouter, Depends, Request

from labjoint import __version__
from labjoint.api.auth import require_control, require_control_or_loopback, require_read
from labjoint.api.errors import ApiError, errors_doc
from labjoint.api.jobs import json_safe
from labjoint.api.schemas import EStopRequest, EStopResult, Health, RigStatus, Version
from labjoint.daemon.liveness import liveness
from labjoint.documents import utc_now

log = logging.getLogger(__name__)
router = APIRouter(tags=["system"])


def mode(request: Request) -> str:
    st = request.app.state
    return "embedded" if st.daemon is not None else "queue" if st.queue is not None else "none"


@router.get("/health", response_model=Health, responses=errors_doc(), summary="Liveness")
def health(request: Request) -> dict[str, Any]:
    """Always open (no token): the service answers, its version and daemon mode."""
    return {"status": "ok", "version": __version__, "daemon": mode(request),
            "time": utc_now()}


@router.get("/version", response_model=Version, responses=errors_doc(), summary="Version",
            dependencies=[Depends(require_read)])
def version(request: Request) -> dict[str, Any]:
    return {"version": __version__, "api_version": "v1", "python": platform.python_version(),
            "openapi_url": request.app.openapi_url}


#: what only a caller with a token sees of the daemon (where files live, process ids)
PRIVATE = ("pid", "worker_id", "data_dir", "queue_db")


@router.get("/rig", response_model=RigStatus, responses=errors_doc(),
            summary="Rig and instrument status")
def rig(request: Request, scope: str | None = Depends(require_read)) -> dict[str, Any]:
    """The daemon's view of the rig (generator settings and output, current job and run,
    samples) and the number of plan jobs in each state. With ``--no-daemon`` the daemon's
    liveness comes from its lock and its last heartbeat: ``state`` is "not running" when
    no daemon holds the queue. Paths and process ids only with a token."""
    st = request.app.state
    out: dict[str, Any] = {"mode": mode(request), "backend": st.backend, "daemon": None,
                           "queue": None, "estop": None}
    if st.daemon is not None:
        out["daemon"] = json_safe({**st.daemon.status(), "running": True})
    elif st.queue is not None:
        out["daemon"] = json_safe(liveness(st.queue))
    if out["daemon"] is not None and scope is None:
        out["daemon"] = {k: v for k, v in out["daemon"].items() if k not in PRIVATE}
    if st.queue is not None:
        out["queue"] = st.queue.counts()
        out["estop"] = st.queue.estop_requested()
    return out


def _stopper(request: Request) -> Any:
    st = request.app.state
    if st.daemon is None and st.queue is None:
        raise ApiError(503, "no_daemon", "this service runs without a daemon or job queue: "
                       "there is nothing to stop from here")
    return st


@router.post("/estop", response_model=EStopResult, responses=errors_doc(503),
             summary="Emergency stop", dependencies=[Depends(require_control_or_loopback)],
             openapi_extra={"security": [{"bearer": []}, {}]})   # no token from loopback
def estop(request: Request, body: EStopRequest | None = None) -> dict[str, Any]:
    """Output off at once (no ramp), the running plan ends 'aborted', and every queued
    plan is held: after the stop is cleared (``POST /estop/clear``) each waits for
    ``POST /plans/{id}/resume`` or is cancelled. Needs a control token, except from the
    machine itself (a loopback client address), so a user at the rig can always stop it."""
    st = _stopper(request)
    reason = (body or EStopRequest()).reason
    log.warning("emergency stop requested through the API: %s",
                reason.encode("unicode_escape").decode("ascii"))
    if st.daemon is not None:
        st.daemon.emergency_stop(reason)
    else:
        st.queue.request_estop(reason)
    q = st.queue if st.queue is not None else st.daemon.queue
    return {"estop": q.estop_requested(), "daemon": mode(request)}


@router.post("/estop/clear", response_model=EStopResult, responses=errors_doc(503),
             summary="Clear an emergency stop", dependencies=[Depends(require_control)])
def estop_clear(request: Request) -> dict[str, Any]:
    """Unlatch an emergency stop. Plans it held stay held until each is resumed
    (``POST /plans/{id}/resume``) or cancelled."""
    st = _stopper(request)
    q = st.queue if st.queue is not None else st.daemon.queue
    log.warning("emergency stop cleared through the API")
    q.clear_estop()
    return {"estop": q.estop_requested(), "daemon": mode(request)}
