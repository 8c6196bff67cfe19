"""Models: fit, diagnose and ladder as jobs calling :mod:`labjoint.compare`.

Each job calls ``labjoint.compare.<operation>(run_paths, model, **options)`` (``ladder``
also gets ``max_steps``) with the runs' files, resolved inside the data directory, and
returns the result (the CLI's JSON; ``options.full`` adds what the web page draws). The
options are checked before the job is queued: an unknown option or a bad value answers
422 naming ``options.<key>``, an unknown effect in the model or the candidates 422
naming it and the vocabulary; runs named in ``options.validate`` go through the catalog
like ``runs``. The job's progress messages are compare's own. Diagnoses and ladders run
in the job runner's long-job worker, so a fit never waits behind one; both can be
cancelled while they run.
"""

from __future__ import annotations

import dataclasses
from typing import Annotated, Any, Callable, Literal

from fastapi import APIRouter, Depends, Path, Query, Request
from pydantic import BaseModel, ConfigDict, Field, ValidationError

import labjoint.compare as compare
from labjoint.api.auth import require_control, require_read, token_label
from labjoint.api.errors import errors_doc
from labjoint.api.modal import MODELS, ModalOptions, _named, check_modal, predict_runs, run_modal
from labjoint.api.progress import ModelProgress
from labjoint.api.routes.analyses import JobStatus, cancel_job, get_job, job_page, runner
from labjoint.api.schemas import JOB_ID, Job, JobList, ModelRequest, RunName
from labjoint.compare.api import settings_from
from labjoint.compare.candidates import candidate_effects
from labjoint.compare.simulation_api import check_options as check_simulation_options
from labjoint.identify.plausible import limits_from
from labjoint.compare.simulation_api import simulation_job
from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.models.simulate import check_simulable

router = APIRouter(prefix="/models", tags=["models"])
OPERATIONS = ("fit", "diagnose", "ladder")
KINDS = (*(f"model_{op}" for op in OPERATIONS), "model_predict")
#: operations that may take minutes: they run in their own worker, so fits never wait
LONG = ("diagnose", "ladder")
Auto = Literal["auto"]


class FitOptions(ModalOptions):
    """Options of every comparison job (see :mod:`labjoint.compare.api`; the modal kind's:
    :mod:`labjoint.api.modal`)."""

    model_config = ConfigDict(extra="forbid")

    validate_: list[RunName] | None = Field(None, alias="validate", max_length=200)
    prime_cycles: Auto | int = Field("auto")
    multistart: Auto | int = Field("auto")
    seed: int = Field(0, ge=0, le=2**32 - 1)
    full: bool = False
    kind: Literal["auto", "sine", "record"] = Field(
        "auto", description="sine: steady cycles; record: any excitation, along the history")
    warmup: Auto | Annotated[float, Field(ge=0, allow_inf_nan=False)] = Field(
        "auto", description="record kind: seconds left unjudged at the start")
    error: Literal["equation", "simulation"] = Field(
        "equation", description="equation: the joint force along the measured history; "
        "simulation: the displacement simulated from the applied force (a model with inertia)")
    periodic: bool = Field(False, description="simulation: each record is whole periods of a "
                                              "steady periodic input")
    plausibility: dict[str, float] | None = Field(
        None, description="plausibility limits checked before the fit, the rig config's "
        "[plausibility] names (max_displacement_amplitude_m, min_samples_per_period, "
        "max_filter_loss, max_frequency_mismatch); default the pipeline's")
    max_displacement: float | None = Field(
        None, gt=0, allow_inf_nan=False, description="largest plausible displacement amplitude "
        "(m) of a steady sine, over plausibility's (the CLI's --max-displacement)")


class DiagnoseOptions(FitOptions):
    alpha: float | None = Field(None, gt=0, lt=1)
    practical: float | None = Field(None, gt=0)
    min_rel: float | None = Field(None, gt=0)
    tie_tol: float | None = Field(None, gt=0)
    tie_corr: float | None = Field(None, gt=0)
    factor: float = Field(1.5, gt=0, allow_inf_nan=False)
    n_jobs: int | None = Field(None, ge=1, le=64)
    candidates: list[str] | str | None = Field(None)
    warm: bool = True


class LadderOptions(DiagnoseOptions):
    auto: bool = True
    save: bool = True


OPTION_MODELS: dict[str, type[FitOptions]] = {
    "fit": FitOptions, "diagnose": DiagnoseOptions, "ladder": LadderOptions}


def check_options(operation: str, options: dict[str, Any], data_dir: Any = None) -> dict[str, Any]:
    """The options as compare takes them; InputError (422) naming ``options.<key>``
    (the modal kind's resolved in ``data_dir``: :func:`labjoint.api.modal.check_modal`)."""
    try:
        opts = OPTION_MODELS[operation].model_validate(options)
    except ValidationError as exc:
        err = exc.errors()[0]
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            known = sorted(f.alias or k for k, f in OPTION_MODELS[operation].model_fields.items())
            msg = f"unknown option for {operation}; known: {known}"
        raise InputError(msg, field=".".join(["options", *map(str, err["loc"][:1])])) from None
    for name, v in (("prime_cycles", opts.prime_cycles), ("multistart", opts.multistart)):
        if isinstance(v, int) and not (0 if name == "prime_cycles" else 1) <= v <= 1000:
            raise InputError("must be 'auto' or a whole number up to 1000 "
                             f"(>= {0 if name == 'prime_cycles' else 1}), got {v}",
                             field=f"options.{name}")
    out = {k: v for k, v in opts.model_dump(by_alias=True).items() if k in options}
    out = check_modal(out, operation, data_dir or ".")
    if "plausibility" in out or "max_displacement" in out:
        if out.get("error") == "simulation":
            raise InputError("the plausibility limits are checked by the equation-error pipeline; "
                             "error = 'simulation' does not take them",
                             field=f"options.{'plausibility' if 'plausibility' in out else 'max_displacement'}")
        try:
            out["plausibility"] = limits_from(out.pop("plausibility", None), out.pop("max_displacement", None))
        except InputError as exc:
            raise InputError(exc.message, field=f"options.{exc.field}") from None
    if out.get("error") == "simulation":
        check_simulation_options(out)
    elif out.get("periodic"):
        raise InputError("periodic goes with error = 'simulation'", field="options.periodic")
    if operation != "fit":
        try:
            settings_from(out)
        except InputError as exc:
            raise InputError(exc.message, field=f"options.{exc.field}") from None
    return out


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
    res = request.app.state.resolver
    names = list(dict.fromkeys(body.runs))
    paths = [res.path(n) for n in names]
    options = check_options(operation, body.options, res.data_dir)
    model = "+".join(p.strip() for p in body.model.split("+"))
    parsed = Model.parse(model)             # an unknown effect is 422 now, not a failed job
    simulation = options.get("error") == "simulation"
    if simulation:
        check_simulable(parsed)
    cands = options.get("candidates")
    only = None
    if cands is not None:
        try:
            only = settings_from({"candidates": cands}).candidates
            candidate_effects(parsed, only)
        except InputError as exc:
            raise InputError(exc.message, field="options.candidates") from None
    if options.get("validate"):      # names -> files inside the data directory
        options["validate"] = [v if v in names else str(res.path(v)) for v in options["validate"]]
    req = {"operation": operation, "runs": names, "model": model,
           "max_steps": body.max_steps, "options": body.options}

    tracker = ModelProgress(operation, model, only, body.max_steps)

    def work(r: dict[str, Any], progress: Callable[[float, str], None]) -> dict[str, Any]:
        progress(0.0, f"{operation} {model}")
        kw = dict(options)
        if simulation:
            return simulation_job(operation, [str(p) for p in paths], model, kw,
                                  max_steps=r["max_steps"],
                                  progress=lambda message: progress(tracker.update(message),
                                                                    str(message)))
        kw.pop("error", None)
        kw.pop("periodic", None)
        kw["progress"] = lambda message: progress(tracker.update(message), str(message))
        if operation == "ladder":
            kw["max_steps"] = r["max_steps"]
        if kw.get("modal") is not None:
            return as_result(run_modal(operation, [str(p) for p in paths], model, kw, res.data_dir))
        fn = getattr(compare, operation)
        return as_result(fn([str(p) for p in paths], model, **kw))

    return runner(request).submit(f"model_{operation}", req, work,
                                  submitted_by=token_label(scope),
                                  long=operation in LONG).to_dict()


@router.post("/fit", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Fit a joint model (a job)")
def fit(request: Request, body: ModelRequest,
        scope: str = Depends(require_control)) -> dict[str, Any]:
    """Fit ``model`` (effects joined by '+') to the runs; poll the returned job."""
    return _submit(request, "fit", body, scope)


@router.post("/diagnose", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Where a model fails (a job)")
def diagnose(request: Request, body: ModelRequest,
             scope: str = Depends(require_control)) -> dict[str, Any]:
    """Residuals of ``model`` and which physical effect is missing; with
    ``options.full`` also the residual maps, curves and measured/model loops per run."""
    return _submit(request, "diagnose", body, scope)


@router.post("/ladder", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Add effects until adequate (a job)")
def ladder(request: Request, body: ModelRequest,
           scope: str = Depends(require_control)) -> dict[str, Any]:
    """Start from ``model`` and add up to ``max_steps`` effects while the error falls;
    the ladder is saved in the runs' files (``GET /runs/{name}/ladders``)."""
    return _submit(request, "ladder", body, scope)


class PredictRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    model_file: RunName = Field(description="a modal model stored by a fit with options.save_as "
                                            "(models/<model_file>.json)")
    runs: list[RunName] = Field(min_length=1, max_length=50)
    full: bool = Field(False, description="with the measured and model series of every channel")


@router.post("/predict", response_model=Job, status_code=202, responses=errors_doc(),
             summary="A stored modal model on runs it never saw (a job)")
def predict(request: Request, body: PredictRequest,
            scope: str = Depends(require_control)) -> dict[str, Any]:
    """``labjoint predict MODEL.json RUN --json`` of a stored modal model on each run: per
    channel and pooled NRMSE, and through the shaker the force on the structure and the
    per-volt and per-newton responses at a sine's fundamental (``{"model_file", "runs"}``)."""
    res = request.app.state.resolver
    names = list(dict.fromkeys(body.runs))
    paths = {n: str(res.path(n)) for n in names}
    _named(res.data_dir, MODELS, body.model_file, "modal model", "model_file")

    def work(r: dict[str, Any], progress: Callable[[float, str], None]) -> dict[str, Any]:
        progress(0.0, f"predict {body.model_file}")
        return predict_runs(res.data_dir, body.model_file, paths, body.full)

    return runner(request).submit("model_predict", body.model_dump(), work,
                                  submitted_by=token_label(scope)).to_dict()


@router.get("/jobs", response_model=JobList, responses=errors_doc(), summary="List model jobs",
            dependencies=[Depends(require_read)])
def list_jobs(request: Request, status: JobStatus | None = Query(None),
              limit: int = Query(50, ge=1, le=500),
              offset: int = Query(0, ge=0, le=10**9)) -> dict[str, Any]:
    return job_page(request, KINDS, status, limit, offset)


@router.post("/jobs/{job_id}/cancel", response_model=Job, responses=errors_doc(409),
             summary="Cancel a model job", dependencies=[Depends(require_control)])
def cancel(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    """A queued job is cancelled at once; a running diagnosis or ladder stops at its next
    step (after the candidate refits in progress; a fit, being short, runs to its end) and
    ends ``cancelled``; ``cancel_requested`` says it was asked. 409 once finished."""
    return cancel_job(request, job_id, KINDS)


@router.get("/jobs/{job_id}", response_model=Job, responses=errors_doc(),
            summary="A model job", dependencies=[Depends(require_read)])
def get(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    return get_job(request, job_id, KINDS)
