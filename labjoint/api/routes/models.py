"""Models: fit, diagnose and ladder as jobs calling :mod:`labjoint.compare`.

Each job calls ``labjoint.compare.<operation>(run_paths, model, **options)`` (``ladder``
also gets ``max_steps``) with the runs' files, resolved inside the data directory, and
returns the result's ``to_dict()``. Until ``labjoint.compare`` provides ``fit``,
``diagnose`` and ``ladder`` the endpoints answer 501 with a clear message: never a
made-up result.
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import Any, Callable, Literal

from fastapi import APIRouter, Depends, Path, Query, Request

from labjoint.api.auth import require_control, require_read, token_label
from labjoint.api.errors import ApiError, errors_doc
from labjoint.api.routes.analyses import get_job, job_page, runner
from labjoint.api.schemas import JOB_ID, Job, JobList, ModelRequest

router = APIRouter(prefix="/models", tags=["models"])
OPERATIONS = ("fit", "diagnose", "ladder")
KINDS = tuple(f"model_{op}" for op in OPERATIONS)
JobStatus = Literal["queued", "running", "complete", "failed", "cancelled"]


def compare_function(operation: str) -> Callable[..., Any]:
    """``labjoint.compare.<operation>``, or 501 while it does not exist."""
    try:
        mod = importlib.import_module("labjoint.compare")
    except ImportError:
        mod = None
    fn = getattr(mod, operation, None)
    if not callable(fn):
        raise ApiError(501, "not_implemented", f"model comparison ({operation}) is not "
                       "available yet: labjoint.compare does not provide it")
    return fn


def as_result(obj: Any) -> dict[str, Any]:
    """A compare result as a JSON-able mapping."""
    for attr in ("to_dict", "summary"):
        f = getattr(obj, attr, None)
        if callable(f):
            obj = f()
            break
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        obj = dataclasses.asdict(obj)
    return obj if isinstance(obj, dict) else {"result": obj}


def _submit(request: Request, operation: str, body: ModelRequest, scope: str) -> dict[str, Any]:
    fn = compare_function(operation)
    res = request.app.state.resolver
    names = list(dict.fromkeys(body.runs))
    paths = [res.path(n) for n in names]
    model = "+".join(p.strip() for p in body.model.split("+"))
    req = {"operation": operation, "runs": names, "model": model,
           "max_steps": body.max_steps, "options": body.options}

    def work(r: dict[str, Any], progress: Callable[[float, str], None]) -> dict[str, Any]:
        progress(0.0, f"{operation} {model}")
        kw = dict(r["options"])
        if operation == "ladder":
            kw["max_steps"] = r["max_steps"]
        return as_result(fn([str(p) for p in paths], model, **kw))

    return runner(request).submit(f"model_{operation}", req, work,
                                  submitted_by=token_label(scope)).to_dict()


@router.post("/fit", response_model=Job, status_code=202, responses=errors_doc(501),
             summary="Fit a joint model (a job)")
def fit(request: Request, body: ModelRequest,
        scope: str = Depends(require_control)) -> dict[str, Any]:
    """Fit ``model`` (effects joined by '+') to the runs; poll the returned job."""
    return _submit(request, "fit", body, scope)


@router.post("/diagnose", response_model=Job, status_code=202, responses=errors_doc(501),
             summary="Where a model fails (a job)")
def diagnose(request: Request, body: ModelRequest,
             scope: str = Depends(require_control)) -> dict[str, Any]:
    """Residuals of ``model`` and which physical effect is missing."""
    return _submit(request, "diagnose", body, scope)


@router.post("/ladder", response_model=Job, status_code=202, responses=errors_doc(501),
             summary="Add effects until adequate (a job)")
def ladder(request: Request, body: ModelRequest,
           scope: str = Depends(require_control)) -> dict[str, Any]:
    """Start from ``model`` and add up to ``max_steps`` effects while the error falls."""
    return _submit(request, "ladder", body, scope)


@router.get("/jobs", response_model=JobList, responses=errors_doc(), summary="List model jobs",
            dependencies=[Depends(require_read)])
def list_jobs(request: Request, status: JobStatus | None = Query(None),
              limit: int = Query(50, ge=1, le=500),
              offset: int = Query(0, ge=0, le=10**9)) -> dict[str, Any]:
    return job_page(request, KINDS, status, limit, offset)


@router.get("/jobs/{job_id}", response_model=Job, responses=errors_doc(),
            summary="A model job", dependencies=[Depends(require_read)])
def get(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    return get_job(request, job_id, KINDS)
