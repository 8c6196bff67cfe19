"""Request and response models of the REST API (published in the OpenAPI schema).

Units are SI and named in the field (``_hz``, ``_m``, ``_n``, ``_nm``); times are ISO
8601 UTC strings.
"""

from __future__ import annotations

import dataclasses
import inspect
from typing import Annotated, Any, Literal, Union, get_type_hints

from pydantic import BaseModel, ConfigDict, Field, create_model

from labjoint.acquisition.plans import PLANS
from labjoint.api.jobs import JobRecord
from labjoint.storage.catalog import RunRecord

#: A run name as stored (see labjoint.storage.layout.check_run_name).
RUN_NAME = r"^[A-Za-z0-9][A-Za-z0-9_.\-]{0,199}$"
#: A job id: hex or a short identifier.
JOB_ID = r"^[A-Za-z0-9_\-]{1,64}$"
#: A model expression: effect names joined by '+'.
MODEL_EXPR = r"^[a-z][a-z0-9_]*( *\+ *[a-z][a-z0-9_]*)*$"

RunName = Annotated[str, Field(pattern=RUN_NAME, description="run name")]


def from_domain(cls: type, name: str, *, exclude: tuple[str, ...] = (),
                overrides: dict[str, Any] | None = None, doc: str = "") -> type[BaseModel]:
    """A response model with the fields, types and defaults of the domain dataclass
    ``cls`` (less ``exclude``; ``overrides``: narrower types), so the REST schema follows
    the domain type instead of mirroring it by hand."""
    hints = get_type_hints(cls)
    fields: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if f.name in exclude:
            continue
        typ = (overrides or {}).get(f.name, hints[f.name])
        if f.default is not dataclasses.MISSING:
            fields[f.name] = (typ, f.default)
        elif f.default_factory is not dataclasses.MISSING:
            fields[f.name] = (typ, Field(default_factory=f.default_factory))
        else:
            fields[f.name] = (typ, ...)
    return create_model(name, __doc__=doc, **fields)


class _In(BaseModel):
    model_config = ConfigDict(extra="forbid")


# ---- system -----------------------------------------------------------------------

class Health(BaseModel):
    status: Literal["ok"]
    version: str
    daemon: Literal["embedded", "queue", "none"] = Field(
        description="embedded: acquisition daemon in this process; queue: attached to a "
                    "separate daemon through the job queue; none: read-only service")
    time: str


class Version(BaseModel):
    version: str
    api_version: Literal["v1"]
    python: str
    openapi_url: str


class RigStatus(BaseModel):
    mode: Literal["embedded", "queue", "none"]
    backend: str | None = Field(None, description="'sim' or 'real' when known")
    daemon: dict[str, Any] | None = Field(
        None, description="the daemon's status: state, generator settings and output, "
                          "current job and run, samples, estop, last error (in queue mode: "
                          "as last published by the daemon, with updated_at)")
    queue: dict[str, int] | None = Field(None, description="number of plan jobs by status")
    estop: str | None = Field(None, description="reason of a pending emergency stop")


class EStopRequest(_In):
    reason: str = Field("emergency stop requested through the API", min_length=1,
                        max_length=200)


class EStopResult(BaseModel):
    estop: str | None = Field(description="reason of the pending emergency stop, null if cleared")
    daemon: Literal["embedded", "queue"] = Field(
        description="embedded: output switched off in this process; queue: the daemon was "
                    "told through the queue and stops within its poll interval")


# ---- plans --------------------------------------------------------------------------

PlanName = Literal[tuple(sorted(PLANS))]  # type: ignore[valid-type]


def _plan_parameters(name: str) -> type[BaseModel]:
    """The parameters of plan ``name`` as a model: its signature's names, types (with
    their limits) and defaults, nothing else allowed."""
    fn = inspect.unwrap(PLANS[name])
    hints = get_type_hints(fn, include_extras=True)
    fields: dict[str, Any] = {}
    for p in inspect.signature(fn).parameters.values():
        default = ... if p.default is inspect.Parameter.empty else p.default
        fields[p.name] = (hints.get(p.name, Any), default)
    doc = (inspect.getdoc(fn) or "").split("\n\n")[0]
    title = "".join(w.title() for w in name.split("_"))
    return create_model(f"{title}Parameters", __config__=ConfigDict(extra="forbid", strict=True),
                        __doc__=f"Parameters of the {name} plan: {doc}", **fields)


def _plan_submit(name: str) -> type[BaseModel]:
    params = _plan_parameters(name)
    title = "".join(w.title() for w in name.split("_"))
    return create_model(
        f"Submit{title}", __base__=_In, __doc__=f"Submit the {name} plan.",
        plan=(Literal[name], Field(description="plan name, see /plan-types")),  # type: ignore[valid-type]
        parameters=(params, Field(default_factory=dict,
                                  description="the plan's keyword arguments (SI units)")),
        submitted_by=(str, Field("", max_length=100)))


#: A plan submission: one schema per plan type, told apart by ``plan``.
PlanSubmit = Annotated[Union[tuple(_plan_submit(n) for n in sorted(PLANS))],  # type: ignore[misc]
                       Field(discriminator="plan")]


class TorqueConfirm(_In):
    torque_nm: float = Field(gt=0, le=1000, allow_inf_nan=False,
                             description="bolt torque now applied (N m)")


PlanStatus = Literal["queued", "held", "running", "waiting_torque", "done", "failed", "cancelled",
                     "aborted"]


class PlanJob(BaseModel):
    """A plan in the daemon's queue and what became of it."""

    id: str
    status: PlanStatus
    plan: dict[str, Any] = Field(description="the plan name ('plan') and its parameters")
    submitted_at: str
    submitted_by: str = ""
    started_at: str | None = None
    finished_at: str | None = None
    progress: float = Field(0.0, description="fraction of the plan's runs recorded")
    message: str = ""
    runs: list[str] = Field(default_factory=list, description="names of the runs recorded")
    waiting_for: dict[str, Any] | None = Field(
        None, description="while waiting_torque: what the operator must do")
    error: str | None = None
    worker: str | None = None
    cancel_requested: bool = False
    gaps: list[dict[str, Any]] = Field(default_factory=list,
                                       description="sample-counter jumps seen")


class PlanJobList(BaseModel):
    items: list[PlanJob]
    limit: int
    offset: int
    next_offset: int | None


class PlanType(BaseModel):
    name: str
    description: str
    parameters: dict[str, Any] = Field(description="parameter name -> default (null: required)")


# ---- runs ---------------------------------------------------------------------------

RunSummary = from_domain(RunRecord, "RunSummary", exclude=("path", "start_ts"),
                         doc="A run as the catalog lists it (storage.catalog.RunRecord).")


#: The loop results a run list shows (labjoint analyze's fields, SI).
RESULT_KEYS = ("energy_loss_j", "damping_ns_per_m", "stiffness_n_per_m", "below_resolution")


class RunResult(BaseModel):
    """A run's latest stored loop result (``labjoint reprocess --pipeline analyze``)."""

    pipeline: str
    status: Literal["complete", "not_applicable", "failed"] = Field(
        description="complete: analysed; not_applicable: a run the pipeline does not handle "
                    "(not a steady sine, no displacement sensor); failed: refused (error)")
    computed_at: str
    version: str = Field(description="pipeline version (code hash) that made it")
    error: str | None = None
    energy_loss_j: float | None = None
    damping_ns_per_m: float | None = None
    stiffness_n_per_m: float | None = None
    below_resolution: bool | None = None


class RunListItem(RunSummary):  # type: ignore[misc,valid-type]
    result: RunResult | None = Field(None, description="latest stored loop result; null: "
                                     "never analysed by reprocess")


class RunList(BaseModel):
    items: list[RunListItem]
    limit: int
    offset: int
    next_offset: int | None = Field(description="offset of the next page, null on the last")
    total: int = Field(description="runs matching the filters, over every page")


class ChannelInfo(BaseModel):
    name: str
    sensor: str
    quantity: str
    unit: str
    sensitivity: float | None
    units_per_volt: float | None = Field(description="calibration applied at the run's frequency")
    range_v: float | None
    coupling: str
    physical_channel: str


class RunChannels(BaseModel):
    name: str
    status: str
    n_samples: int
    sample_rate_hz: float
    duration_s: float
    channels: list[ChannelInfo]
    derived: dict[str, list[str]] = Field(
        description="derived series: 'displacement' (relative, m) and 'force' (joint, N)")


class Series(BaseModel):
    name: str
    unit: str
    quantity: str
    time_s: list[float | None]
    values: list[float | None]


class DataSlice(BaseModel):
    run: str
    start_sample: int
    stop_sample: int
    sample_rate_hz: float
    bucket: int = Field(description="samples per min/max bucket; 1 = raw samples")
    decimated: bool
    series: list[Series]


# ---- analyses and models ---------------------------------------------------------

class AnalysisRequest(_In):
    runs: list[RunName] = Field(min_length=1, max_length=200)
    method: Literal["hysteresis", "stick_slip", "both"] = "hysteresis"
    options: dict[str, Any] = Field(default_factory=dict,
                                    description="keyword options of the pipeline")


class ModelRequest(_In):
    runs: list[RunName] = Field(min_length=1, max_length=200)
    model: str = Field("linear_stiffness+viscous", pattern=MODEL_EXPR, max_length=400,
                       description="effects joined by '+', see the effect vocabulary")
    max_steps: int = Field(5, ge=1, le=20, description="ladder: most effects added")
    options: dict[str, Any] = Field(default_factory=dict)


Job = from_domain(JobRecord, "Job", overrides={
    "status": Literal["queued", "running", "complete", "failed", "cancelled"]},
    doc="An analysis or model job (api.jobs.JobRecord).")


class JobList(BaseModel):
    items: list[Job]
    limit: int
    offset: int
    next_offset: int | None


# ---- loops and saved ladders of a run -----------------------------------------------

class LoopCycle(BaseModel):
    """One steady cycle: its loop resampled over exactly one period and its seed 002
    Eq. 1 quantities (as the hysteresis-loop pipeline computed them)."""

    index: int = Field(description="cycle number in the run (0: the first whole cycle)")
    start_s: float = Field(description="time of the cycle's start: the displacement "
                                       "fundamental's upward zero crossing")
    frequency_hz: float | None = Field(description="1 / the cycle's duration")
    displacement_amplitude_m: float | None
    force_amplitude_n: float | None
    energy_loss_j: float | None = Field(description="loop area (seed 002 Eq. 1's W_d)")
    damping_ns_per_m: float | None = Field(description="W_d / (pi omega U^2), seed 002 Eq. 1")
    energy_loss_uncertainty_j: float | None = Field(
        None, description="standard uncertainty of W_d: calibrated sensor phase and "
                          "cycle-to-cycle scatter (labjoint.identify.resolution)")
    below_resolution: bool = Field(False, description="W_d is below twice its uncertainty "
                                   "(at least 2 pi K U^2 u_phase): not a result")
    stiffness_n_per_m: float | None = Field(description="least-squares slope of F on U")
    stiffness_secant_n_per_m: float | None
    displacement_m: list[float | None] = Field(description="relative displacement, evenly "
                                               "spaced in time over one period (not closed)")
    force_n: list[float | None] = Field(description="joint force at the same instants")


class ClippedChannel(BaseModel):
    """A stored channel that sat at its input range (labjoint.signal.clipping)."""

    channel: str
    level: float = Field(description="the value it sat at, in the channel's unit")
    unit: str
    fraction: float = Field(description="fraction of the samples in flat tops")


class RunLoops(BaseModel):
    """The hysteresis loops of a run's steady cycles (empty, with a reason, if none)."""

    run: str
    status: str
    complete: bool = Field(description="false while the run is still being recorded: the "
                                       "cycles are those recorded so far")
    n_samples: int = Field(description="samples analysed")
    sample_rate_hz: float
    frequency_hz: float | None
    cutoff_hz: float | None = Field(description="zero-phase low-pass cutoff applied")
    n_cycles: int = Field(description="whole cycles found")
    n_steady: int = Field(description="steady cycles")
    steady_start: int | None
    steady_stop: int | None
    points_per_cycle: int = Field(description="points per cycle returned")
    cycles: list[LoopCycle] = Field(description="the last steady cycles, oldest first")
    summary: dict[str, float | int | None] = Field(
        description="mean and std over every steady cycle (labjoint analyze's fields)")
    reason: str | None = Field(description="why no cycle is returned; null when some are")
    refused: str | None = Field(None, description="the field the loop pipeline refused the run "
                                "for ('excitation': not a steady sine; a channel: clipped); "
                                "null when it analysed the run or found no cycle")
    clipped: list[ClippedChannel] = Field(default_factory=list, description="stored channels "
                                          "whose input range was exceeded (flat tops)")
    warnings: list[str]


class SavedLadderStep(BaseModel):
    model_config = ConfigDict(extra="allow")

    model: str
    added: str | None = None
    nrmse: float | None = None
    nrmse_validation: float | None = None
    adequate: bool | None = None
    verdict: str | None = None
    parameters: dict[str, Any] = Field(default_factory=dict)
    candidates: list[dict[str, Any]] = Field(default_factory=list)


class SavedLadder(BaseModel):
    """A ladder as ``labjoint ladder`` saved it in the run file (not recomputed)."""

    model_config = ConfigDict(extra="allow")

    key: str = Field(description="id of the ladder's question: runs, start, mode, split")
    saved_at: str | None = Field(None, description="when it was written (UTC)")
    start: str
    final_model: str
    adequate: bool
    noise_floor: float | None = None
    noise_floor_validation: float | None = None
    stop_reason: str | None = None
    runs: list[str] = Field(default_factory=list)
    fit_runs: list[str] = Field(default_factory=list)
    validation_runs: list[str] = Field(default_factory=list)
    steps: list[SavedLadderStep]


class RunLadders(BaseModel):
    run: str
    ladders: list[SavedLadder] = Field(description="newest first")
    damaged: dict[str, str] = Field(default_factory=dict,
                                    description="ladder groups that could not be read -> why")
