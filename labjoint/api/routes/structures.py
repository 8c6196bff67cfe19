"""Structures: modes, stage-1 and stage-2 updating, model FRFs, and model jobs on FRF sets
and backbones.

Structure files (TOML, :mod:`labjoint.structure.config`) live in the data directory's
``structures/`` folder, FRF set files (JSON, :mod:`labjoint.signal.frfset`) in its
``frf/`` folder; a request names them by file stem, which is looked up among the
folder's files (nothing a client sends is joined into a path). Modes answer at once;
updating, FRFs and the comparison (fit, diagnose, ladder of a joint model inside the
structure on FRF sets and stored backbones, ``backbones/`` folder:
:mod:`labjoint.compare.frf_api`, :mod:`labjoint.compare.backbone_api`) are jobs: model jobs are listed, polled and
cancelled with ``/models/jobs``, the others with ``/structures/jobs``. A ladder is saved
beside its FRF and backbone files (``<stem>.model_ladder_<key>.json``).
"""

from __future__ import annotations

from pathlib import Path as FsPath
from typing import Annotated, Any, Callable, Literal

from fastapi import APIRouter, Depends, Path, Query, Request
from pydantic import BaseModel, ConfigDict, Field

import labjoint.compare as compare
from labjoint.api.auth import require_control, require_read, token_label
from labjoint.api.errors import errors_doc, not_found
from labjoint.api.routes.analyses import JobStatus, cancel_job, get_job, job_page, runner
from labjoint.api.resolve import find_named
from labjoint.api.routes.models import as_result
from labjoint.api.schemas import JOB_ID, MODEL_EXPR, RUN_NAME, Job, JobList
from labjoint.compare.api import settings_from
from labjoint.compare.kinds import FRF
from labjoint.errors import InputError

router = APIRouter(prefix="/structures", tags=["structures"])
STRUCTURES, FRFSETS, BACKBONES = "structures", "frf", "backbones"
#: names a file cannot have: ``/structures/jobs/{id}`` would shadow ``/structures/{name}/...``
RESERVED = frozenset({"jobs"})
KINDS = ("structure_update", "structure_frf", "structure_stage2", "structure_curves")
Name = Annotated[str, Field(pattern=RUN_NAME)]
Hz = Annotated[float, Field(gt=0, le=1e5, allow_inf_nan=False)]


class _In(BaseModel):
    model_config = ConfigDict(extra="forbid")


class UpdateRequest(_In):
    measured_hz: list[Hz] = Field(min_length=1, max_length=20)
    parameter: str = Field("E_e_pa", max_length=100, pattern=r"^[A-Za-z0-9_.]+$")


class FrfRequest(_In):
    force_n: float = Field(gt=0, le=1e5, allow_inf_nan=False)
    band_hz: list[Hz] = Field(min_length=2, max_length=2)
    harmonics: int = Field(3, ge=1, le=9)
    modes: int = Field(10, ge=0, le=100)


class Stage2Request(_In):
    frfsets: list[Name] = Field(min_length=1, max_length=20)
    parameters: list[Annotated[str, Field(max_length=100, pattern=r"^[a-z_]+\.[A-Za-z_]+$")]] | None = None
    modes: int = Field(10, ge=0, le=100)


class CurvesRequest(_In):
    frfsets: list[Name] = Field(min_length=1, max_length=20)
    model: str = Field(pattern=MODEL_EXPR, max_length=400)
    parameters: dict[Annotated[str, Field(max_length=100, pattern=r"^[a-z_]+\.[A-Za-z0-9_]+$")],
                     Annotated[float, Field(allow_inf_nan=False)]] = Field(max_length=50)
    points: int = Field(200, ge=20, le=1000)
    margin: float = Field(0.25, ge=0, le=2, allow_inf_nan=False)
    modes: int = Field(10, ge=0, le=100)
    harmonics: int | None = Field(None, ge=1, le=3)


class FrfModelOptions(_In):
    validate_: list[Name] | None = Field(None, alias="validate", max_length=50)
    seed: int = Field(0, ge=0, le=2**32 - 1)
    full: bool = False
    factor: float = Field(1.5, gt=0, allow_inf_nan=False)
    alpha: float | None = Field(None, gt=0, lt=1)
    candidates: list[Annotated[str, Field(max_length=40)]] | None = None
    modes: int = Field(10, ge=0, le=100)
    harmonics: int | None = Field(None, ge=1, le=3)
    linear_damping: Literal["file", "measured"] = Field(
        "file", description="backbones: the structure's linear damping from its file, or identified "
                            "from the backbones' low-amplitude linear range")
    save: bool = True


class FrfModelRequest(_In):
    frfsets: list[Name] = Field(default_factory=list, max_length=20)
    backbones: list[Name] = Field(default_factory=list, max_length=20,
                                  description="stored backbone files (GET /backbones), judged with the FRF sets")
    model: str = Field("linear_stiffness", pattern=MODEL_EXPR, max_length=400)
    max_steps: int = Field(3, ge=1, le=10)
    options: FrfModelOptions = Field(default_factory=FrfModelOptions)


def named_file(request: Request, folder: str, name: str, suffix: str) -> FsPath:
    """The file ``<name><suffix>`` among the data directory's ``folder`` (404 if absent)."""
    if name in RESERVED:
        raise InputError(f"{name!r} is a reserved name (the /structures/{name}/ routes); rename "
                         f"{folder}/{name}{suffix}", field="name")
    found = find_named(request.app.state.resolver.data_dir, folder, name, suffix)
    if found is not None:
        return found
    raise not_found({STRUCTURES: "structure", FRFSETS: "frf set"}.get(folder, "backbone file"), name)


def _listing(request: Request, folder: str, suffix: str) -> list[str]:
    base = FsPath(request.app.state.resolver.data_dir) / folder
    if not base.is_dir():
        return []
    return sorted(p.stem for p in base.iterdir() if p.is_file() and p.suffix == suffix
                  and not p.name.startswith(".") and ".model_" not in p.name
                  and p.stem not in RESERVED)


@router.get("", responses=errors_doc(), summary="Structure and FRF set files",
            dependencies=[Depends(require_read)])
def listing(request: Request) -> dict[str, Any]:
    """Names of the structure files (``structures/*.toml``) and FRF sets (``frf/*.json``);
    files with a reserved name (``jobs``) are listed under ``refused`` with the reason."""
    out: dict[str, Any] = {"structures": _listing(request, STRUCTURES, ".toml"),
                           "frfsets": _listing(request, FRFSETS, ".json")}
    base = FsPath(request.app.state.resolver.data_dir)
    refused = {f"{d}/{n}{x}": f"{n!r} is a reserved name (the /structures/{n}/ routes): rename it"
               for d, x in ((STRUCTURES, ".toml"), (FRFSETS, ".json")) for n in sorted(RESERVED)
               if (base / d / f"{n}{x}").is_file()}
    if refused:
        out["refused"] = refused
    return out


@router.get("/jobs", response_model=JobList, responses=errors_doc(),
            summary="List structure jobs", dependencies=[Depends(require_read)])
def list_jobs(request: Request, status: JobStatus | None = Query(None),
              limit: int = Query(50, ge=1, le=500),
              offset: int = Query(0, ge=0, le=10**9)) -> dict[str, Any]:
    return job_page(request, KINDS, status, limit, offset)


@router.get("/jobs/{job_id}", response_model=Job, responses=errors_doc(),
            summary="A structure job", dependencies=[Depends(require_read)])
def get(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    return get_job(request, job_id, KINDS)


@router.post("/jobs/{job_id}/cancel", response_model=Job, responses=errors_doc(409),
             summary="Cancel a structure job", dependencies=[Depends(require_control)])
def cancel(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    return cancel_job(request, job_id, KINDS)


@router.get("/{name}/modes", responses=errors_doc(), summary="Natural frequencies",
            dependencies=[Depends(require_read)])
def modes(request: Request, name: str = Path(pattern=RUN_NAME),
          count: int = Query(4, ge=1, le=50)) -> dict[str, Any]:
    """Natural frequencies (Hz) and mode shapes at the sensors, joints stuck."""
    from labjoint.structure import load_structure
    from labjoint.structure.modal import modes as modal

    s = load_structure(named_file(request, STRUCTURES, name, ".toml"))
    m = modal(s, min(count, s.n))
    return {"structure": s.name, "dofs": s.n, "frequencies_hz": m.frequencies_hz.tolist(),
            "mode_shapes_at_sensors": {nm: (s.sensors[i] @ m.shapes).tolist()
                                       for i, nm in enumerate(s.sensor_names)}}


def _job(request: Request, kind: str, req: dict[str, Any], scope: str,
         work: Callable[[Callable[[float, str], None]], dict[str, Any]], long: bool = True
         ) -> dict[str, Any]:
    return runner(request).submit(kind, req, lambda r, progress: work(progress),
                                  submitted_by=token_label(scope), long=long).to_dict()


@router.post("/{name}/update", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Stage-1 updating from natural frequencies (a job)")
def update(request: Request, body: UpdateRequest, name: str = Path(pattern=RUN_NAME),
           scope: str = Depends(require_control)) -> dict[str, Any]:
    """The joint's E_e (or another stiffness parameter) from measured natural frequencies
    (seed 000 Eqs. 7-8)."""
    from labjoint.structure import load_structure, update_stiffness

    path = named_file(request, STRUCTURES, name, ".toml")

    def work(progress: Callable[[float, str], None]) -> dict[str, Any]:
        s = load_structure(path)
        return {"structure": s.name, **update_stiffness(s, body.measured_hz, body.parameter).to_dict()}

    return _job(request, "structure_update", {"structure": name, **body.model_dump()}, scope, work, False)


@router.post("/{name}/frf", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Model FRF at constant force (a job)")
def frf(request: Request, body: FrfRequest, name: str = Path(pattern=RUN_NAME),
        scope: str = Depends(require_control)) -> dict[str, Any]:
    """Continuation over ``band_hz`` at force amplitude ``force_n`` (harmonic balance)."""
    from labjoint.structure import load_structure
    from labjoint.structure.frf import frf as model_frf

    path = named_file(request, STRUCTURES, name, ".toml")
    lo, hi = sorted(body.band_hz)
    if not lo < hi:
        raise InputError("the band needs two different frequencies", field="band_hz")

    def work(progress: Callable[[float, str], None]) -> dict[str, Any]:
        s = load_structure(path)
        r = model_frf(s, body.force_n, (lo, hi), harmonics=body.harmonics, modes=body.modes)
        return {"structure": s.name, **r.to_dict()}

    return _job(request, "structure_frf", {"structure": name, **body.model_dump()}, scope, work)


@router.post("/{name}/stage2", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Stage-2 updating on FRF sets (a job)")
def stage2(request: Request, body: Stage2Request, name: str = Path(pattern=RUN_NAME),
           scope: str = Depends(require_control)) -> dict[str, Any]:
    """The joint law's nonlinear parameters (E_p, S_Y, n by default) on the FRF residual
    (seed 000 Eq. 9): fitted around mode 1, validated around mode 2, with standard errors."""
    from labjoint.signal.frfset import FrfSet, concat
    from labjoint.structure import load_structure
    from labjoint.structure.predict import FrfPredictor
    from labjoint.structure.stage2 import update_nonlinear

    path = named_file(request, STRUCTURES, name, ".toml")
    files = [named_file(request, FRFSETS, n, ".json") for n in dict.fromkeys(body.frfsets)]
    structure = load_structure(path)
    law = structure.joints[0].law if structure.joints else None
    for p in body.parameters or ():
        if law is None or p not in law.params:
            known = ", ".join(law.params) if law else "none: the structure has no joint"
            raise InputError(f"{p} is not a parameter of the joint law ({known})", field="parameters")

    def work(progress: Callable[[float, str], None]) -> dict[str, Any]:
        fs = concat([FrfSet.load(f) for f in files])
        pr = FrfPredictor(structure, body.modes, harmonics=1)
        return update_nonlinear(pr, fs, body.parameters).to_dict()

    return _job(request, "structure_stage2", {"structure": name, **body.model_dump()}, scope, work)


@router.post("/{name}/curves", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Model FRFs evaluated densely beside the measured steps (a job)")
def curves(request: Request, body: CurvesRequest, name: str = Path(pattern=RUN_NAME),
           scope: str = Depends(require_control)) -> dict[str, Any]:
    """Per sweep of the FRF sets (a level, a direction, the steps around one mode): the
    measured steps and the joint model ``model`` with ``parameters`` (e.g. a diagnosis's
    candidate or a ladder's step) solved by harmonic balance on ``points`` frequencies
    over the steps and ``margin`` x their span around them, every sensor and harmonic as
    magnitude per newton and phase (:mod:`labjoint.compare.frf_curves`)."""
    from labjoint.compare.frf_curves import checked_law, dense_curves

    path = named_file(request, STRUCTURES, name, ".toml")
    files = [str(named_file(request, FRFSETS, n, ".json")) for n in dict.fromkeys(body.frfsets)]
    checked_law(body.model, body.parameters)             # refused before it is queued
    opts: dict[str, Any] = {"structure": str(path), "modes": body.modes}
    if body.harmonics is not None:
        opts["harmonics"] = body.harmonics

    def work(progress: Callable[[float, str], None]) -> dict[str, Any]:
        return dense_curves(files, body.model, body.parameters, opts, body.points, body.margin)

    return _job(request, "structure_curves", {"structure": name, **body.model_dump()}, scope, work,
                False)


@router.post("/{name}/models/{operation}", response_model=Job, status_code=202,
             responses=errors_doc(), summary="Fit, diagnose or ladder a joint model on FRF sets (a job)")
def model_job(request: Request, body: FrfModelRequest, name: str = Path(pattern=RUN_NAME),
              operation: Literal["fit", "diagnose", "ladder"] = Path(),
              scope: str = Depends(require_control)) -> dict[str, Any]:
    """The comparison loop with the joint model inside the structure on FRF sets (the
    ``frf`` kind: residuals over frequency x level x harmonic), stored backbones (the
    ``backbone`` kind: frequency and damping over amplitude) or both in one comparison;
    candidates ranked against the data's own noise floor; poll with ``/models/jobs/{id}``."""
    from labjoint.models import Model

    path = named_file(request, STRUCTURES, name, ".toml")
    if not body.frfsets and not body.backbones:
        raise InputError("name FRF sets, backbones or both", field="frfsets")
    files = [str(named_file(request, FRFSETS, n, ".json")) for n in dict.fromkeys(body.frfsets)]
    files += [str(named_file(request, BACKBONES, n, ".json")) for n in dict.fromkeys(body.backbones)]
    Model.parse(body.model)
    o = body.options.model_dump(by_alias=True, exclude_unset=True)
    kw: dict[str, Any] = {"structure": str(path), "modes": body.options.modes}
    for k in ("seed", "full", "harmonics", "linear_damping"):
        if k in o:
            kw[k] = o[k]
    if operation != "fit":
        kw.update({k: o[k] for k in ("factor", "alpha", "candidates") if k in o})
    if operation == "ladder":
        kw.update(max_steps=body.max_steps, save=body.options.save)
    if body.options.validate_:
        kw["validate"] = [named_file(request, BACKBONES if n in body.backbones else FRFSETS, n, ".json").stem
                          for n in body.options.validate_]
    if "candidates" in kw:
        try:
            FRF.candidates(Model.parse(body.model), settings_from({"candidates": kw["candidates"]}).candidates)
        except InputError as exc:
            raise InputError(exc.message, field="options.candidates") from None

    def work(progress: Callable[[float, str], None]) -> dict[str, Any]:
        kw["progress"] = lambda message: progress(0.5, str(message)) if operation != "fit" else None
        if operation == "fit":
            kw.pop("progress")
        return as_result(getattr(compare, operation)(files, body.model, **kw))

    req = {"operation": operation, "structure": name, "frfsets": body.frfsets,
           "backbones": body.backbones, "model": body.model,
           "max_steps": body.max_steps, "options": o}
    return _job(request, f"model_{operation}", req, scope, work, long=operation != "fit")
