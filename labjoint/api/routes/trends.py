"""Trends: energy loss, damping and stiffness of a set of runs by both methods of seed
002, seed 002 Tables 2-4 and the dissipation exponent of seed 001, for the runs a
catalog filter selects (the filters of ``GET /runs``) or the runs named."""

from __future__ import annotations

import re
from typing import Any, Literal

from fastapi import APIRouter, Depends, Query, Request
from fastapi.responses import JSONResponse

from labjoint.api.auth import require_read
from labjoint.api.errors import errors_doc
from labjoint.api.jobs import json_safe
from labjoint.api.clipped import friction_flag
from labjoint.api.routes.runs import list_runs
from labjoint.api.schemas import RUN_NAME
from labjoint.api.trend_schemas import Trends
from labjoint.errors import InputError, LabjointError
from labjoint.identify.identified import load_identified
from labjoint.identify.stickslip import MAX_FRICTION, MIN_FRICTION
from labjoint.identify.trends import build_trends, trend_row
from labjoint.storage import read_run

router = APIRouter(prefix="/trends", tags=["trends"], dependencies=[Depends(require_read)])
#: Most runs named in one request (the filter's ``limit`` bounds the rest).
MAX_NAMED = 1000


def _message(exc: LabjointError) -> str:
    """The error without the server's file path."""
    if isinstance(exc, InputError):
        return str(InputError(exc.message, line=exc.line, column=exc.column, field=exc.field))
    return str(exc)


@router.get("", response_model=Trends, responses=errors_doc(), summary="Trends of runs")
def trends(
    request: Request,
    page: dict[str, Any] = Depends(list_runs),
    run: list[str] = Query(default_factory=list, max_length=MAX_NAMED,
                           description="runs by name; when given, these runs are taken "
                                       "and the catalog filters are not applied"),
    friction_coefficient: float | None = Query(
        None, ge=MIN_FRICTION, le=MAX_FRICTION, allow_inf_nan=False,
        description="for the stick-slip method; default: the latest friction test in "
                    "<data_dir>/identified.json (none: the loop method alone)"),
    force: Literal["joint", "reference"] = Query("joint", description="force sensor"),
) -> JSONResponse:
    """Energy loss, damping and stiffness of each run by the hysteresis loop (seed 002
    Eq. 1, measured) and the stick-slip boundary (Eqs. 6-9, model), with standard
    uncertainties, against excitation, displacement and force amplitude and torque; the
    seed 002 Tables 2-4 layout; and the dissipation exponent n of W = a F^n (seed 001,
    Segalman: n = 3 + chi, 2.5-3 in micro-slip) by weighted least squares on log axes
    with its 95 % interval (refused, with the reason in ``fit.error``, for fewer than
    3 distinct amplitudes). Runs are those of the catalog filters (the parameters of
    ``GET /runs``, ``limit`` runs at most) or the ``run`` names. A run that cannot be
    analysed (not a steady sine, too short, a missing channel) is listed in ``errors``."""
    res = request.app.state.resolver
    if run:
        for n in run:
            if not re.match(RUN_NAME, n):
                raise InputError(f"{n[:40]!r} is not a run name", field="run")
        names = list(dict.fromkeys(run))
        for n in names:
            res.path(n)                      # 404 for an unknown run, before any work
        truncated = False
    else:
        names = [r["name"] for r in page["items"]]
        truncated = page["next_offset"] is not None
    mu: Any = friction_coefficient
    if mu is None:
        mu = load_identified(res.data_dir, "friction_coefficient")
    rows, errors = [], []
    for n in names:
        try:
            rows.append(trend_row(read_run(res.path(n), force=force), mu))
        except LabjointError as exc:
            errors.append({"run": n, "error": _message(exc)})
    body = build_trends(rows, errors)
    flag = friction_flag(res, getattr(mu, "source", None)) if body["methods"] != ["loop"] else None
    body["friction_flag"] = flag
    if flag:
        body["notes"].insert(0, f"Stick-slip columns: {flag}")
    body["selection"] = {"runs": names, "truncated": truncated}
    if truncated:
        body["notes"].append(f"more runs match than the {len(names)} taken (limit): "
                             "narrow the filter or raise limit")
    return JSONResponse(json_safe(body))
