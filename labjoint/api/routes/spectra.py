"""FRFs, modes and the distortion report of catalogued runs, as jobs (issue 28 item 7).

Each job calls the pipeline behind the CLI (:mod:`labjoint.identify.spectral`) and its
result is the CLI's ``--json`` answer: ``POST /spectra/frf`` is ``labjoint frf RUN...
--out frf/<name>.json`` (the FRF set is stored in the data directory's ``frf/`` folder,
beside the structures' FRF sets, and read back with ``GET /spectra/frf/{name}``);
``POST /spectra/modes`` is ``labjoint modes`` on runs or on stored FRF sets;
``POST /spectra/distortion`` is ``labjoint distortion``. Runs are resolved through the
catalog and FRF sets among the ``frf/`` folder's files (nothing a client sends becomes a
path). Channels named in a request are checked against the runs' headers before a job
is queued (422 naming the run and the channel); what only the samples tell (a sine where
a broadband record is needed) fails the job with ``invalid_input`` and the message.
Answers name files relative to the data directory, never the server's own paths.
"""

from __future__ import annotations

from pathlib import Path as FsPath
from typing import Annotated, Any, Callable, Literal

from fastapi import APIRouter, Depends, Path, Query, Request
from fastapi.responses import Response
from pydantic import BaseModel, ConfigDict, Field, model_validator

from labjoint.api.auth import require_control, require_read, token_label
from labjoint.api.errors import ApiError, errors_doc
from labjoint.api.routes.analyses import JobStatus, cancel_job, get_job, job_page, runner
from labjoint.api.routes.structures import FRFSETS, RESERVED, _listing, named_file
from labjoint.api.schemas import JOB_ID, RUN_NAME, Job, JobList
from labjoint.errors import InputError

router = APIRouter(prefix="/spectra", tags=["spectra"])
KINDS = ("spectra_frf", "spectra_modes", "spectra_distortion")
Name = Annotated[str, Field(pattern=RUN_NAME)]
Hz = Annotated[float, Field(ge=0, le=1e6, allow_inf_nan=False)]


class _In(BaseModel):
    model_config = ConfigDict(extra="forbid")


class FrfOptions(_In):
    """What `labjoint frf` and `labjoint modes` take besides the files."""

    drive: Name | None = Field(None, description="drive channel (default: the one force, "
                                                 "else the one voltage)")
    responses: list[Name] | None = Field(None, min_length=1, max_length=64,
                                         description="response channels (default: all)")
    estimator: Literal["H1", "H2", "Hv"] = "H1"
    method: Literal["auto", "welch", "periodic", "burst", "block"] = "auto"
    burst: Literal["block", "driven"] = Field(
        "block", description="a burst record's estimator: 'block' (one unwindowed block per burst, "
                             "its free decay included: Testlab's burst-random H1) or 'driven' (the "
                             "driven part through the local rational method: the FRF at the "
                             "burst's own amplitude, for a nonlinear structure)")
    nperseg: int | None = Field(None, ge=16, le=1 << 24, description="Welch segment (samples)")
    overlap: float | None = Field(None, ge=0, lt=1)
    window: str = Field("hann", pattern=r"^[a-z_]{1,40}$", description="Welch window (scipy)")


class FrfRequest(FrfOptions):
    runs: list[Name] = Field(min_length=1, max_length=50)
    name: Name = Field(description="the FRF set's name: stored as frf/<name>.json")
    band: Literal["drive", "all"] | Annotated[list[Hz], Field(min_length=2, max_length=2)] = Field(
        "drive", description="lines kept: [lo, hi] Hz, 'drive' (where the drive carries power) "
                             "or 'all'")
    overwrite: bool = Field(False, description="replace a stored set of that name")


class ModesRequest(FrfOptions):
    runs: list[Name] | None = Field(None, min_length=1, max_length=50)
    frfsets: list[Name] | None = Field(None, min_length=1, max_length=20,
                                       description="stored FRF sets (frf/<name>.json)")
    band: Annotated[list[Hz], Field(min_length=2, max_length=2)] | None = Field(
        None, description="[lo, hi] Hz (default: the set's band)")
    order: int | None = Field(None, ge=2, le=400, description="highest LSCF model order")

    @model_validator(mode="after")
    def _one_source(self) -> "ModesRequest":
        if (self.runs is None) == (self.frfsets is None):
            raise ValueError("name either runs or frfsets")
        return self


class DistortionRequest(_In):
    runs: list[Name] = Field(min_length=1, max_length=50)
    drive: Name | None = None
    orders: int = Field(5, ge=2, le=20, description="harmonics 2..orders")
    blocks: int = Field(8, ge=2, le=200, description="blocks of whole cycles for the spread")
    bands: int = Field(6, ge=1, le=50, description="multisine: bands of the excited range")


def _options(body: BaseModel, **extra: Any) -> Any:
    from labjoint.identify.spectral import SpectralOptions

    d = body.model_dump()
    keep = {k: d[k] for k in SpectralOptions.__dataclass_fields__ if k in d}
    if isinstance(keep.get("responses"), list):
        keep["responses"] = ",".join(keep["responses"])
    keep.update(extra)
    return SpectralOptions(**keep)


def _band_text(band: Any) -> str | None:
    if band is None or isinstance(band, str):
        return band
    lo, hi = band
    if not lo < hi:
        raise InputError(f"must be [lo, hi] with lo < hi, got {band}", field="band")
    return f"{lo}:{hi}"


def _check(request: Request, names: list[str], drive: str | None,
           responses: list[str] | None) -> list[str]:
    """The runs' files, after checking the named (or the default) drive and responses in
    each run's header: 422 naming the run and the channel."""
    from labjoint.identify.records import header

    res = request.app.state.resolver
    paths = []
    for n in names:
        p = res.path(n)
        try:
            rec = header(str(p))
            rec.drive(drive)
            rec.responses(responses)
        except InputError as exc:
            raise InputError(f"run {n!r}: {exc.message}", field=exc.field) from None
        paths.append(str(p))
    return paths


def _segment(names: list[str], paths: list[str], nperseg: int | None) -> None:
    """A given Welch segment fits every run (16 to its samples): 422 naming the run, the
    field and the range before any job is queued."""
    from labjoint.identify.records import sample_count
    from labjoint.signal.broadband import check_nperseg

    if nperseg is None:
        return
    for n, p in zip(names, paths):
        try:
            check_nperseg(nperseg, sample_count(p))
        except InputError as exc:
            raise InputError(f"run {n!r}: {exc.message}", field=exc.field) from None


def _window(name: str) -> None:
    from scipy.signal import get_window

    try:
        get_window(name, 16)
    except ValueError:
        raise InputError(f"unknown window {name!r} (a scipy.signal window name)",
                         field="window") from None


def _private(data_dir: FsPath) -> Callable[[Any], Any]:
    """A result with the data directory's paths made relative (no server paths leave)."""
    root = str(data_dir) + "/"

    def clean(x: Any) -> Any:
        if isinstance(x, str):
            return x.replace(root, "")
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, list):
            return [clean(v) for v in x]
        return x
    return clean


def _work(request: Request, fn: Callable[[Callable[[float, str], None]], dict[str, Any]]
          ) -> Callable[[dict[str, Any], Callable[[float, str], None]], dict[str, Any]]:
    clean = _private(FsPath(request.app.state.resolver.data_dir))

    def work(_req: dict[str, Any], progress: Callable[[float, str], None]) -> dict[str, Any]:
        try:
            return clean(fn(progress))
        except InputError as exc:
            raise InputError(clean(str(exc)), field=exc.field) from None
    return work


def _submit(request: Request, kind: str, body: BaseModel, scope: str, fn: Any,
            long: bool) -> dict[str, Any]:
    return runner(request).submit(kind, body.model_dump(), _work(request, fn),
                                  submitted_by=token_label(scope), long=long).to_dict()


@router.post("/frf", response_model=Job, status_code=202, responses=errors_doc(409),
             summary="FRFs of broadband runs, stored as an FRF set (a job)")
def frf(request: Request, body: FrfRequest,
        scope: str = Depends(require_control)) -> dict[str, Any]:
    """H1/H2/Hv with coherence and standard deviations, one level per run (``labjoint
    frf``); the set is written whole to ``frf/<name>.json`` (409 if it exists and
    ``overwrite`` is false). The result is ``labjoint frf --json``'s: ``path``, ``format``,
    ``levels``, and ``name``."""
    from labjoint.identify.spectral import frf_out

    if body.name in RESERVED:
        raise InputError(f"{body.name!r} is a reserved name", field="name")
    _window(body.window)
    band = _band_text(body.band)
    names = list(dict.fromkeys(body.runs))
    paths = _check(request, names, body.drive, body.responses)
    _segment(names, paths, body.nperseg)
    folder = FsPath(request.app.state.resolver.data_dir) / FRFSETS
    out = folder / f"{body.name}.json"
    if out.exists() and not body.overwrite:
        raise ApiError(409, "conflict", f"FRF set {body.name!r} exists; send overwrite=true "
                       "to replace it")
    opts = _options(body, frf_band=band)

    def run(progress: Callable[[float, str], None]) -> dict[str, Any]:
        folder.mkdir(parents=True, exist_ok=True)
        return {**frf_out(paths, out, opts, progress), "name": body.name}
    return _submit(request, "spectra_frf", body, scope, run, long=True)


@router.post("/modes", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Modes per level of runs or stored FRF sets (a job)")
def modes(request: Request, body: ModesRequest,
          scope: str = Depends(require_control)) -> dict[str, Any]:
    """Natural frequency, damping ratio and mode shape per level (LSCF/LSFD, half-power
    beside), ``labjoint modes --json``'s ``{"levels": [...]}``."""
    from labjoint.identify.spectral import modes_levels

    _window(body.window)
    band = _band_text(body.band)
    if body.frfsets is not None:
        inputs = [str(named_file(request, FRFSETS, n, ".json")) for n in dict.fromkeys(body.frfsets)]
    else:
        names = list(dict.fromkeys(body.runs or []))
        inputs = _check(request, names, body.drive, body.responses)
        _segment(names, inputs, body.nperseg)
    opts = _options(body, band=band)

    def run(progress: Callable[[float, str], None]) -> dict[str, Any]:
        progress(0.0, "modes")
        return {"levels": modes_levels(inputs, opts)}
    return _submit(request, "spectra_modes", body, scope, run, long=body.runs is not None)


@router.post("/distortion", response_model=Job, status_code=202, responses=errors_doc(),
             summary="Distortion report of steady-sine or multisine runs (a job)")
def distortion(request: Request, body: DistortionRequest,
               scope: str = Depends(require_control)) -> dict[str, Any]:
    """Harmonic ratios h_k/h_1 with standard errors per channel (steady sines), or the
    odd and even nonlinear distortion against the noise per band (multisines):
    ``labjoint distortion --json``'s ``{"runs": [...]}``."""
    from labjoint.identify.spectral import distortion_runs

    names = list(dict.fromkeys(body.runs))
    paths = _check(request, names, body.drive, None)
    opts = _options(body, drive=body.drive, orders=body.orders, blocks=body.blocks,
                    bands=body.bands)
    return _submit(request, "spectra_distortion", body, scope,
                   lambda progress: distortion_runs(paths, opts, progress), long=False)


@router.get("/frf", responses=errors_doc(), summary="Stored FRF sets",
            dependencies=[Depends(require_read)])
def frf_sets(request: Request) -> dict[str, Any]:
    """Names of the FRF sets in ``frf/`` (what ``name`` and ``frfsets`` take)."""
    return {"frfsets": _listing(request, FRFSETS, ".json")}


@router.get("/frf/{name}", responses=errors_doc(), summary="A stored FRF set",
            dependencies=[Depends(require_read)])
def frf_set(request: Request, name: str = Path(pattern=RUN_NAME)) -> Response:
    """The FRF set file as stored (``labjoint.frfset/1``: frequencies, complex responses as
    re/im, coherence, std, quantity, units, levels)."""
    p = named_file(request, FRFSETS, name, ".json")
    return Response(p.read_bytes(), media_type="application/json")


@router.get("/jobs", response_model=JobList, responses=errors_doc(),
            summary="List FRF, modes and distortion jobs", dependencies=[Depends(require_read)])
def list_jobs(request: Request, status: JobStatus | None = Query(None),
              limit: int = Query(50, ge=1, le=500),
              offset: int = Query(0, ge=0, le=10**9)) -> dict[str, Any]:
    return job_page(request, KINDS, status, limit, offset)


@router.get("/jobs/{job_id}", response_model=Job, responses=errors_doc(),
            summary="An FRF, modes or distortion job", dependencies=[Depends(require_read)])
def get(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    return get_job(request, job_id, KINDS)


@router.post("/jobs/{job_id}/cancel", response_model=Job, responses=errors_doc(409),
             summary="Cancel an FRF, modes or distortion job",
             dependencies=[Depends(require_control)])
def cancel(request: Request, job_id: str = Path(pattern=JOB_ID)) -> dict[str, Any]:
    """A queued job is cancelled at once; a running one stops before its next run."""
    return cancel_job(request, job_id, KINDS)
