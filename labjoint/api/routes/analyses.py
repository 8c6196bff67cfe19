"""Analyses: run the identification pipelines on runs as jobs, poll them, get results."""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, Depends, Path, Query, Request

from labjoint.api.analysis import parse_options, run_analysis
from labjoint.api.auth import require_control, require_read, token_label
from labjoint.api.errors import ApiError, errors_doc, not_found
from labjoint.api.jobs import JobRunner
from labjoint.api.schemas import JOB_ID, AnalysisRequest, Job, JobList

router = APIRouter(prefix="/analyses", tags=["analyses"])
KINDS = ("analysis",)
JobStatus = Literal["queued", "running", "complete", "failed", "cancelled"]


def runner(request: Request) -> JobRunner:
    return request.app.state.jobs


def job_page(request: Request, kinds: tuple[str, ...], status: str | None, limit: int,
             offset: int) -> dict[str, Any]:
    rows = runner(request).list(kinds, status, limit + 1, offset)
    return {"items": [r.to_dict() for r in rows[:limit]], "limit": limit, "offset": offset,
            "next_offset": offset + limit if len(rows) > limit else None}


def get_job(request: Request, job_id: str, kinds: tuple[str, ...]) -> dict[str, Any]:
    job = runner(request).get(job_id)
    if job is None or job.kind not in kinds:
        raise not_found("job", job_id)
    return job.to_dict()


@router.post("", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Analyse runs (a job)")
def submit(request: Request, body: AnalysisRequest,
           scope: str = Depends(require_control)) -> dict[str, Any]:
    """Start a pipeline on runs: ``hysteresis`` (seed 002 Eq. 1), ``stick_slip`` (Eqs.
    2-9, needs a friction coefficient) or ``both`` side by side. Poll the returned job."""
    res = request.app.state.resolver
    names = list(dict.fromkeys(body.runs))
    for n in names:
        res.path(n)  # 404/403 first, before the options, and not inside the job
    opts = parse_options(body.method, body.options, res.data_dir)
    job = runner(request).submit(
        "analysis", {"method": body.method, "runs": names, "options": opts},
        lambda req, progress: run_analysis(res, req["method"], req["runs"], req["options"],
                                           progress),
        submitted_by=token_label(scope))
    return job.to_dict()


@router.get("", response_model=JobList, responses=errors_doc(), summary="List analysis jobs",
            dependencies=[Depends(require_read)])
def list_jobs(request: Request, status: JobStatus | None = Query(None),
              limit: int = Query(50, ge=1, le=500),
              offset: int = Query(0, ge=0, le=10**9)) -> dict[str, Any]:
    return job_page(request, KINDS, status, limit, offset)


@router.get("/{job_id}", response_model=Job, responses=errors_doc(), summary="An analysis job",
            dependencies=[Depends(require_read)])
def get(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    """The job: status, progress and, once complete, the results per run."""
    return get_job(request, job_id, KINDS)


@router.post("/{job_id}/cancel", response_model=Job, responses=errors_doc(409),
             summary="Cancel a queued analysis", dependencies=[Depends(require_control)])
def cancel(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    """Cancel the job if it has not started yet (409 once it runs or has finished)."""
    return cancel_job(request, job_id, KINDS)


def cancel_job(request: Request, job_id: str, kinds: tuple[str, ...]) -> dict[str, Any]:
    """Cancel a queued job, or ask a running one to stop (409 once it has finished)."""
    before = get_job(request, job_id, kinds)
    job = runner(request).cancel(job_id)
    if before["status"] not in ("queued", "running") or (job.status != "cancelled"
                                                         and not job.cancel_requested):
        raise ApiError(409, "conflict", f"job {job_id} is {job.status}; only a queued or "
                       "running job can be cancelled")
    return job.to_dict()
