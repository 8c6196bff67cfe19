"""Reprocess: a pipeline over the runs a catalog query selects, as a job like any other.

The job plans from the catalog (:mod:`labjoint.batch.reprocess`: current results are
skipped), runs the tasks where the service's settings say (``reprocess_scheduler``:
``none`` in the job's own thread, ``local`` a Dask LocalCluster for the job, or a lab's
scheduler address; never an address from the request), reports progress as tasks end,
and stops starting tasks once cancelled. Its result is the CLI's ``--json`` object.
"""

from __future__ import annotations

from pathlib import Path as FilePath
from typing import Any, Callable, Literal

from fastapi import APIRouter, Depends, Path, Query, Request
from pydantic import BaseModel, ConfigDict, Field

from labjoint.api.auth import require_control, require_read, token_label
from labjoint.api.errors import errors_doc
from labjoint.api.routes.analyses import JobStatus, cancel_job, get_job, job_page, runner
from labjoint.api.schemas import JOB_ID, Job, JobList
from labjoint.batch.options import check_options
from labjoint.batch.reprocess import SerialRunner, execute, plan_reprocess
from labjoint.errors import InputError
from labjoint.storage.results import Results

router = APIRouter(prefix="/reprocess", tags=["reprocess"])
KINDS = ("reprocess",)
Range = float | tuple[float | None, float | None]


class RunQuery(BaseModel):
    """The filters of ``GET /runs`` / ``labjoint runs``: a value or [lo, hi] (SI)."""

    model_config = ConfigDict(extra="forbid")

    torque_nm: Range | None = None
    vpp: Range | None = None
    frequency_hz: Range | None = None
    status: str | None = Field(None, max_length=40)
    plan: str | None = Field(None, max_length=200)


class ReprocessRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    pipeline: Literal["analyze", "stickslip", "fit", "diagnose", "ladder"]
    query: RunQuery = Field(default_factory=RunQuery)
    options: dict[str, Any] = Field(default_factory=dict,
                                    description="pipeline options (labjoint reprocess's)")
    group_by: str | None = Field(None, pattern=r"^[a-z][a-z0-9_]{0,40}$",
                                 description="fit/diagnose/ladder: one group per value")
    recompute: bool = Field(False, description="compute even current results")


@router.post("", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Reprocess catalogued runs (a job)")
def submit(request: Request, body: ReprocessRequest,
           scope: str = Depends(require_control)) -> dict[str, Any]:
    """Run a pipeline over the runs the query selects; runs whose result is current are
    skipped. Bad options and a query matching nothing answer 422 before any job."""
    st = request.app.state
    data_dir = FilePath(st.settings.data_dir).resolve()
    try:
        opts = check_options(body.pipeline, body.options, data_dir)
    except InputError as exc:
        raise InputError(exc.message, field=f"options.{exc.field}") from None
    q = body.query
    records = [r for r in st.catalog.query(torque_nm=q.torque_nm, vpp=q.vpp,
                                           frequency_hz=q.frequency_hz, status=q.status,
                                           plan=q.plan)
               if FilePath(r.path).resolve().is_relative_to(data_dir)]
    results = Results(st.catalog)
    plan = plan_reprocess(results, records, body.pipeline, opts, group_by=body.group_by,
                          force=body.recompute)
    scheduler = st.settings.reprocess_scheduler
    request_doc = {"pipeline": body.pipeline, "query": q.model_dump(exclude_none=True),
                   "options": opts, "group_by": body.group_by, "recompute": body.recompute,
                   "runs": len(records), "tasks": len(plan.tasks)}

    def work(req: dict[str, Any], progress: Callable[[float, str], None]) -> dict[str, Any]:
        progress(0.0, f"{len(plan.tasks)} to compute, {len(plan.skipped)} current")

        def step(done: int, total: int, note: str) -> None:
            progress(done / max(total, 1), f"{done}/{total} {note}")

        if scheduler == "none" or not plan.tasks:
            return execute(plan, SerialRunner(), results, step)
        from labjoint.batch.cluster import DaskRunner, dashboard_line, dask_client
        with dask_client(scheduler) as client:
            progress(0.0, dashboard_line(client))
            report = execute(plan, DaskRunner(client), results, step)
            report["dashboard"] = client.dashboard_link
            return report

    return runner(request).submit("reprocess", request_doc, work,
                                  submitted_by=token_label(scope), long=True).to_dict()


@router.get("", response_model=JobList, responses=errors_doc(), summary="List reprocess jobs",
            dependencies=[Depends(require_read)])
def list_jobs(request: Request, status: JobStatus | None = Query(None),
              limit: int = Query(50, ge=1, le=500),
              offset: int = Query(0, ge=0, le=10**9)) -> dict[str, Any]:
    return job_page(request, KINDS, status, limit, offset)


@router.get("/{job_id}", response_model=Job, responses=errors_doc(),
            summary="A reprocess job", dependencies=[Depends(require_read)])
def get(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    """Status, progress (tasks done / tasks) and, once complete, the report per run."""
    return get_job(request, job_id, KINDS)


@router.post("/{job_id}/cancel", response_model=Job, responses=errors_doc(409),
             summary="Cancel a reprocess", dependencies=[Depends(require_control)])
def cancel(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    """A queued job is cancelled at once; a running one starts no more tasks (those
    running finish and are recorded) and ends ``cancelled``. 409 once finished."""
    return cancel_job(request, job_id, KINDS)
