"""Runs: catalog queries, metadata, the HDF5 file, data slices in physical units, the
hysteresis loops of the steady cycles and the model ladders saved in a run file."""

from __future__ import annotations

import math
from typing import Any, Callable, Literal

import numpy as np
from fastapi import APIRouter, Depends, Path, Query, Request
from fastapi.responses import FileResponse, JSONResponse, Response
from pydantic import ValidationError

from labjoint.api.auth import require_read
from labjoint.api.decimate import CHUNK_SAMPLES, decimate
from labjoint.api.errors import ApiError, errors_doc
from labjoint.api.fastpath import summary, summary_body
from labjoint.api.jobs import json_safe
from labjoint.api.loops import steady_loops
from labjoint.api.resolve import RunResolver, roles
from labjoint.api.schemas import (RESULT_KEYS, RUN_NAME, DataSlice, RunChannels, RunLadders,
                                  RunList, RunLoops, RunSummary, SavedLadder)
from labjoint.compare.store import PREFIX as LADDER_PREFIX
from labjoint.compare.store import load_ladder
from labjoint.errors import InputError
from labjoint.storage import RunFile, RunRecord, open_run
from labjoint.storage.results import Results

router = APIRouter(prefix="/runs", tags=["runs"], dependencies=[Depends(require_read)])

NamePath = Path(pattern=RUN_NAME, description="run name", max_length=200)
ORDERS = ("start_time", "-start_time", "name", "-name", "excitation_vpp", "-excitation_vpp",
          "torque_nm", "-torque_nm", "frequency_hz", "-frequency_hz")
STATUSES = ("running", "complete", "failed", "aborted", "limit", "incomplete")
MAX_OFFSET = 10**9
ISO_TIME = r"^\d{4}-\d{2}-\d{2}([T ]\d{2}:\d{2}(:\d{2}(\.\d{1,6})?)?)?(Z|[+-]\d{2}:\d{2})?$"


def resolver(request: Request) -> RunResolver:
    return request.app.state.resolver


#: Pipelines whose latest stored result the run list shows (labjoint reprocess).
LISTED = ("analyze",)


def _results(catalog: Any, names: list[str]) -> dict[str, dict[str, Any]]:
    """run -> its latest stored loop result: W, C, K when analysed; the reason when
    refused ("not_applicable": not what the pipeline handles; "failed")."""
    out: dict[str, dict[str, Any]] = {}
    for run, rows in Results(catalog).for_runs(names).items():
        rows = [r for r in rows if r.pipeline in LISTED]
        if not rows:
            continue
        r = max(rows, key=lambda x: x.computed_at)
        status = r.status if r.status == "complete" else \
            "not_applicable" if r.summary.get("not_applicable") else "failed"
        out[run] = {"pipeline": r.pipeline, "status": status, "computed_at": r.computed_at,
                    "version": r.version, "error": r.error or None,
                    **{k: r.summary.get(k) for k in RESULT_KEYS}}
    return out


@router.get("", response_model=RunList, responses=errors_doc(), summary="List runs")
def list_runs(
    request: Request,
    torque_nm: float | None = Query(None, gt=0, allow_inf_nan=False,
                                    description="bolt torque (N m)"),
    vpp_min: float | None = Query(None, ge=0, allow_inf_nan=False,
                                  description="lowest excitation (Vpp)"),
    vpp_max: float | None = Query(None, ge=0, allow_inf_nan=False,
                                  description="highest excitation (Vpp)"),
    frequency_hz: float | None = Query(None, gt=0, allow_inf_nan=False),
    status: Literal[STATUSES] | None = Query(None),  # type: ignore[valid-type]
    plan: str | None = Query(None, max_length=64, pattern=r"^[A-Za-z0-9_\-]+$"),
    since: str | None = Query(None, pattern=ISO_TIME,
                              description="started at or after (ISO 8601; naive = UTC)"),
    until: str | None = Query(None, pattern=ISO_TIME,
                              description="started at or before (ISO 8601; naive = UTC)"),
    search: str | None = Query(None, max_length=100,
                               description="part of the run name (case-insensitive)"),
    order: Literal[ORDERS] = Query("start_time"),  # type: ignore[valid-type]
    limit: int = Query(100, ge=1, le=1000),
    offset: int = Query(0, ge=0, le=MAX_OFFSET),
) -> dict[str, Any]:
    """Runs matching every filter given, one page at a time (``next_offset`` pages on;
    ``total`` counts every match)."""
    vpp = None if vpp_min is None and vpp_max is None else (vpp_min, vpp_max)
    filters = dict(torque_nm=torque_nm, vpp=vpp, frequency_hz=frequency_hz, status=status,
                   plan=plan, since=since, until=until, search=search)
    catalog = resolver(request).catalog
    recs = catalog.query(**filters, order=order, limit=limit + 1, offset=offset)
    more = len(recs) > limit
    found = _results(catalog, [r.name for r in recs[:limit]])
    items = [{**summary(r), "result": json_safe(found.get(r.name))} for r in recs[:limit]]
    return {"items": items, "limit": limit, "offset": offset,
            "next_offset": offset + limit if more else None, "total": catalog.count(**filters)}


@router.get("/{name}", response_model=RunSummary, responses=errors_doc(), summary="Run metadata")
async def get_run(request: Request, name: str = NamePath) -> JSONResponse:
    """The run's catalog entry: conditions (SI), status and every other metadata key.

    Async and answered directly: one indexed SQLite lookup (well under a millisecond)
    costs less than a thread-pool hop. The body is cached per catalog version
    (:mod:`labjoint.api.fastpath`, which answers most of these before the router)."""
    return Response(summary_body(request.app.state, name), media_type="application/json")


@router.get("/{name}/channels", response_model=RunChannels, responses=errors_doc(),
            summary="Channels of a run")
def get_channels(request: Request, name: str = NamePath) -> dict[str, Any]:
    """Stored channels (sensor, unit, calibration) and the derived series available."""
    with resolver(request).open(name) as rf:
        fs = rf.sample_rate_hz
        chans = [{**{k: v for k, v in c.to_dict().items() if k in (
                     "name", "sensor", "quantity", "unit", "sensitivity", "range_v",
                     "coupling", "physical_channel")},
                  "units_per_volt": c.units_per_volt(rf.frequency_hz)} for c in rf.channels]
        derived = {k: v for k, v in roles(rf).items() if v}
        return json_safe({"name": rf.name, "status": rf.status, "n_samples": rf.n_samples,
                          "sample_rate_hz": fs, "duration_s": rf.n_samples / fs,
                          "channels": chans, "derived": derived})


@router.get("/{name}/file", response_class=FileResponse, summary="Download the HDF5 run file",
            responses={**errors_doc(409), 200: {
                "description": "the NeXus/HDF5 run file",
                "content": {"application/x-hdf5": {"schema": {"type": "string",
                                                              "format": "binary"}}}}})
def download(request: Request, name: str = NamePath) -> FileResponse:
    """The run's HDF5 file as stored (raw volts, calibrations, processed results)."""
    res = resolver(request)
    rec = res.record(name)
    if rec.status == "running":
        raise ApiError(409, "run_in_progress", f"run {name!r} is still being written; "
                       "download it when it has finished (data slices work meanwhile)")
    return FileResponse(res.path(name), media_type="application/x-hdf5",
                        filename=f"{rec.name}.h5")


def _reader(rf: RunFile, channel: str) -> tuple[Callable[[int, int], np.ndarray], str, str]:
    """read(a, b) in physical units, unit and quantity of a stored or derived series."""
    if channel in rf.channel_names:
        spec = rf.channel(channel)
        return (lambda a, b: rf.physical(channel, a, b)), spec.unit, spec.quantity
    r = roles(rf)
    if channel == "displacement" and r["displacement"]:
        d = r["displacement"]
        if len(d) == 2:
            return (lambda a, b: rf.physical(d[0], a, b) - rf.physical(d[1], a, b)), "m", \
                "displacement"
        return (lambda a, b: rf.physical(d[0], a, b)), "m", "displacement"
    if channel in ("force", "reference_force") and r[channel]:
        c = r[channel][0]
        return (lambda a, b: rf.physical(c, a, b)), rf.channel(c).unit, "force"
    known = rf.channel_names + [k for k, v in r.items() if v and k not in rf.channel_names]
    raise ApiError(404, "no_such_channel", f"run {rf.name!r} has no channel {channel!r}; "
                   f"channels: {known}")


def _times_at(rf: RunFile, idx: np.ndarray) -> np.ndarray:
    """Time axis values (s) at sorted sample indices, read a chunk at a time."""
    out = np.empty(idx.size)
    if idx.size == 0:
        return out
    pos = 0
    for a in range(int(idx[0]), int(idx[-1]) + 1, CHUNK_SAMPLES):
        b = min(a + CHUNK_SAMPLES, int(idx[-1]) + 1)
        end = int(np.searchsorted(idx, b))
        if end > pos:
            out[pos:end] = rf.time(a, b)[idx[pos:end] - a]
            pos = end
    return out


def _to_samples(x: float | None, unit: str, fs: float, n: int, default: int) -> int:
    if x is None:
        return default
    i = x if unit == "samples" else math.ceil(x * fs - 1e-9)
    return int(min(max(i, 0), n))


@router.get("/{name}/data", response_model=DataSlice, responses=errors_doc(),
            summary="A data slice in physical units")
def data_slice(
    request: Request,
    name: str = NamePath,
    channel: list[str] = Query(default_factory=list, max_length=16,
                               description="stored channel, or 'displacement' / 'force' / "
                                           "'reference_force' (derived); default: all stored"),
    start: float = Query(0.0, ge=0, le=1e12, allow_inf_nan=False,
                         description="first sample, in `unit`"),
    stop: float | None = Query(None, ge=0, le=1e12, allow_inf_nan=False,
                               description="end (exclusive), in `unit`; default: run end"),
    unit: Literal["s", "samples"] = Query("s", description="unit of start/stop"),
    max_points: int = Query(2000, ge=10, le=1_000_000,
                            description="most points per series (min/max decimation); "
                                        "capped by the server's [api] max_points"),
) -> JSONResponse:
    """Samples ``start:stop`` of some channels in physical units; long slices are
    min/max decimated so every peak survives in a plot."""
    settings = request.app.state.settings
    cap = min(max_points, settings.max_points)
    with resolver(request).open(name) as rf:
        fs, n = rf.sample_rate_hz, rf.n_samples
        a = _to_samples(start, unit, fs, n, 0)
        b = max(a, _to_samples(stop, unit, fs, n, n))
        names = list(dict.fromkeys(channel)) or rf.channel_names
        readers = [(c, *_reader(rf, c)) for c in names]
        picked = [(c, u, q, *decimate(read, a, b, cap)) for c, read, u, q in readers]
        all_idx = np.unique(np.concatenate([p[3] for p in picked])) if picked else np.zeros(0, int)
        t_all = _times_at(rf, all_idx)
        series, bucket = [], 1
        for c, u, q, idx, values, bk in picked:
            bucket = max(bucket, bk)
            t = t_all[np.searchsorted(all_idx, idx)]
            series.append({"name": c, "unit": u, "quantity": q, "time_s": t, "values": values})
    body = {"run": name, "start_sample": a, "stop_sample": b, "sample_rate_hz": fs,
            "bucket": bucket, "decimated": bucket > 1, "series": series}
    return JSONResponse(json_safe(body))


@router.get("/{name}/loops", response_model=RunLoops, responses=errors_doc(),
            summary="Hysteresis loops of the steady cycles")
def loops(
    request: Request,
    name: str = NamePath,
    points_per_cycle: int = Query(128, ge=8, le=1024,
                                  description="most points per cycle (fewer when a cycle "
                                              "holds fewer samples)"),
    max_cycles: int = Query(8, ge=1, le=200, description="most cycles: the last steady ones"),
    force: Literal["joint", "reference"] = Query("joint", description="force sensor"),
) -> JSONResponse:
    """Displacement (m) and force (N) over each of the run's last steady cycles, with
    their energy loss, damping and stiffness (seed 002 Eq. 1), found by the hysteresis-loop
    pipeline as ``labjoint analyze`` runs it. A run without steady cycles (too short, a
    transient only, no displacement channel) gets an empty list and the reason; a run
    still being recorded gets the cycles recorded so far (``complete`` false)."""
    with resolver(request).open(name) as rf:
        body = steady_loops(rf, points_per_cycle, max_cycles, force)
    body["run"] = name
    return JSONResponse(json_safe(body))


@router.get("/{name}/ladders", response_model=RunLadders, responses=errors_doc(),
            summary="Model ladders saved in the run file")
def ladders(request: Request, name: str = NamePath) -> JSONResponse:
    """Every ladder ``labjoint ladder`` (or a ladder job) saved in this run's file, as
    saved: steps with their NRMSE, the noise floor, the runs of the set. Not recomputed."""
    res = resolver(request)
    path = res.path(name)
    found: list[dict[str, Any]] = []
    damaged: dict[str, str] = {}
    with open_run(path) as rf:
        groups = [g for g in rf.processed_names if g.startswith(LADDER_PREFIX)]
        dates = {g: rf.processed(g)[0].get("date") for g in groups}
    for g in groups:
        try:
            lad = load_ladder(path, g[len(LADDER_PREFIX):])
            if not isinstance(lad, dict):
                raise InputError("not a JSON object")
        except InputError as exc:
            damaged[g] = exc.message
            continue
        date = dates.get(g)
        try:
            item = SavedLadder.model_validate(json_safe(
                {**lad, "saved_at": date if isinstance(date, str) else None}))
        except ValidationError as exc:
            damaged[g] = f"not a ladder: {exc.errors()[0]['msg']}"
            continue
        found.append(item.model_dump())
    found.sort(key=lambda d: d["saved_at"] or "", reverse=True)
    return JSONResponse(json_safe({"run": name, "ladders": found, "damaged": damaged}))
