"""Plans: submit to the daemon's job queue, list, cancel, continue after a torque change."""

from __future__ import annotations

import dataclasses
import inspect
from typing import Any

from fastapi import APIRouter, Depends, Path, Query, Request
from pydantic import BaseModel

from labjoint.acquisition.plans import PLANS
from labjoint.api.auth import require_control, require_read, token_label
from labjoint.api.errors import ApiError, errors_doc, not_found
from labjoint.api.jobs import json_safe
from labjoint.api.schemas import (JOB_ID, PlanJob, PlanJobList, PlanStatus, PlanSubmit, PlanType,
                                  TorqueConfirm)

router = APIRouter(tags=["plans"])
JobId = Path(pattern=JOB_ID, description="plan job id")


def queue(request: Request) -> Any:
    q = request.app.state.queue
    if q is None:
        raise ApiError(503, "no_queue", "this service has no job queue (started without a "
                       "daemon and without --no-daemon's queue)")
    return q


def job_dict(job: Any) -> dict[str, Any]:
    return json_safe(dataclasses.asdict(job))


def _job(request: Request, job_id: str) -> Any:
    job = queue(request).get(job_id)
    if job is None:
        raise not_found("plan job", job_id)
    return job


@router.get("/plan-types", response_model=list[PlanType], responses=errors_doc(),
            summary="Plans the daemon can run", dependencies=[Depends(require_read)])
def plan_types() -> list[dict[str, Any]]:
    """Every plan name with its parameters and their defaults (SI units)."""
    out = []
    for name, fn in sorted(PLANS.items()):
        params = {}
        for p in inspect.signature(fn).parameters.values():
            required = p.default is inspect.Parameter.empty
            params[p.name] = {"required": required,
                              "default": None if required else json_safe(p.default)}
        doc = inspect.getdoc(fn) or ""
        out.append({"name": name, "description": doc.split("\n\n")[0], "parameters": params})
    return out


@router.post("/plans", response_model=PlanJob, status_code=202, responses=errors_doc(503),
             summary="Submit a plan")
def submit(request: Request, body: PlanSubmit,
           scope: str = Depends(require_control)) -> dict[str, Any]:
    """Queue ``plan`` with its parameters; the daemon runs it. Poll the returned job.
    Parameters are checked against the plan type's schema and the rig's limits first."""
    q = queue(request)
    p = body.parameters      # a dict when left out (the plan's defaults then apply)
    given = p.model_dump(mode="json", exclude_unset=True) if isinstance(p, BaseModel) else dict(p)
    job_id = q.submit({"plan": body.plan, **given},
                      submitted_by=body.submitted_by or token_label(scope))
    return job_dict(_job(request, str(job_id)))


@router.get("/plans", response_model=PlanJobList, responses=errors_doc(503),
            summary="List plan jobs", dependencies=[Depends(require_read)])
def list_plans(request: Request,
               status: PlanStatus | None = Query(None),
               limit: int = Query(50, ge=1, le=500),
               offset: int = Query(0, ge=0, le=10**9)) -> dict[str, Any]:
    rows = queue(request).list(status=status, limit=limit + 1, offset=offset)
    return {"items": [job_dict(j) for j in rows[:limit]], "limit": limit, "offset": offset,
            "next_offset": offset + limit if len(rows) > limit else None}


@router.get("/plans/{job_id}", response_model=PlanJob, responses=errors_doc(503),
            summary="A plan job", dependencies=[Depends(require_read)])
def get_plan(request: Request, job_id: str = JobId) -> dict[str, Any]:
    """Status, progress, the runs recorded so far, and what the job waits for."""
    return job_dict(_job(request, job_id))


@router.post("/plans/{job_id}/cancel", response_model=PlanJob, responses=errors_doc(409, 503),
             summary="Cancel a plan", dependencies=[Depends(require_control)])
def cancel(request: Request, job_id: str = JobId) -> dict[str, Any]:
    """Cancel a queued plan, or stop a running one (output ramped off); 409 if finished."""
    _job(request, job_id)
    return job_dict(queue(request).cancel(job_id))


@router.post("/plans/{job_id}/resume", response_model=PlanJob, responses=errors_doc(409, 503),
             summary="Resume a plan held by an emergency stop",
             dependencies=[Depends(require_control)])
def resume(request: Request, job_id: str = JobId) -> dict[str, Any]:
    """A plan held by an emergency stop goes back to the queue (409 while the stop is
    latched or when the plan is not held). Clearing the stop resumes nothing by itself."""
    _job(request, job_id)
    return job_dict(queue(request).resume(job_id))


@router.post("/plans/{job_id}/torque", response_model=PlanJob, responses=errors_doc(409, 503),
             summary="Continue after a torque change", dependencies=[Depends(require_control)])
def continue_torque(request: Request, body: TorqueConfirm, job_id: str = JobId) -> dict[str, Any]:
    """Confirm the bolt torque now applied so a plan paused for it continues (409 if the
    job is not waiting for a torque change)."""
    _job(request, job_id)
    return job_dict(queue(request).continue_torque(job_id, body.torque_nm))
