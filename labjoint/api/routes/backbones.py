"""Backbones: frequency and damping ratio against amplitude from catalogued runs.

``POST /backbones`` names runs (phase_resonance levels and their ringdown, or step_sine
runs); they are resolved through the catalog (:class:`~labjoint.api.resolve.RunResolver`,
nothing a client sends becomes a path) and analysed at once by
:func:`labjoint.identify.backbone.measured_backbones`: the answer is the CLI's
``labjoint backbone --json`` without the model (``points``, ``notes``, ``sensor``).
With ``save_as`` the backbones are also stored as a backbone file (``labjoint.backbone/1``)
in the data directory's ``backbones/`` folder, listed by ``GET /backbones`` and read by
``GET /backbones/{name}``; stored backbones are what the comparison loop on a structure
takes (``POST /structures/{name}/models/{operation}`` with ``backbones``, beside FRF sets).
"""

from __future__ import annotations

from pathlib import Path as FsPath
from typing import Annotated, Any

from fastapi import APIRouter, Depends, Path, Request
from pydantic import BaseModel, ConfigDict, Field

from labjoint.api.auth import require_control, require_read
from labjoint.api.errors import errors_doc
from labjoint.api.schemas import RUN_NAME
from labjoint.errors import InputError
from labjoint.signal.backbone import FORMAT

#: the data directory's folder of backbone files
FOLDER = "backbones"

router = APIRouter(prefix="/backbones", tags=["backbones"])
Name = Annotated[str, Field(pattern=RUN_NAME)]


class BackboneRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    runs: list[Name] = Field(min_length=1, max_length=200)
    modal_mass_kg: float | None = Field(None, gt=0, le=1e6, allow_inf_nan=False)
    sensor: Name | None = None
    save_as: Name | None = Field(None, description="store as backbones/<save_as>.json")
    mode: int = Field(1, ge=1, le=100, description="the mode the backbones are of (1-based)")
    overwrite: bool = False


class BackbonePointOut(BaseModel):
    model_config = ConfigDict(extra="allow")
    amplitude: float
    amplitude_units: str
    frequency_hz: float
    damping_ratio: float
    method: str
    amplitude_sd: float
    frequency_sd_hz: float
    damping_sd: float


class BackboneOut(BaseModel):
    points: list[BackbonePointOut]
    notes: list[str]
    sensor: str | None
    saved: str | None = None


@router.post("", response_model=BackboneOut, responses=errors_doc(), summary="Backbones of runs",
             dependencies=[Depends(require_control)])
def backbones(request: Request, body: BackboneRequest) -> dict[str, Any]:
    """Frequency and damping ratio against the fundamental's displacement amplitude at the
    response sensor, with uncertainties, by method (phase resonance, force-corrected
    ringdown, step sine)."""
    from labjoint.api.routes.structures import RESERVED
    from labjoint.identify.backbone import measured_backbones
    from labjoint.signal.backbone import save_backbones

    res = request.app.state.resolver
    paths = [res.path(n) for n in dict.fromkeys(body.runs)]
    target = None
    if body.save_as is not None:
        if body.save_as in RESERVED:
            raise InputError(f"{body.save_as!r} is a reserved name", field="save_as")
        target = FsPath(res.data_dir) / FOLDER / f"{body.save_as}.json"
        if target.exists() and not body.overwrite:
            raise InputError(f"backbones/{body.save_as}.json exists; set overwrite to replace it",
                             field="save_as")
    try:
        meas = measured_backbones(paths, body.sensor, body.modal_mass_kg)
    except InputError as exc:          # the message without the server's paths
        raise InputError(exc.message, field=exc.field) from None
    if target is not None:
        target.parent.mkdir(exist_ok=True)
        save_backbones(target, meas, body.mode)
    return {"points": [p.to_dict(b.amplitude_units) for b in meas for p in b.points],
            "notes": [n for b in meas for n in b.notes], "sensor": meas[0].sensor if meas else None,
            "saved": body.save_as if target is not None else None}


@router.get("", responses=errors_doc(), summary="Stored backbone files",
            dependencies=[Depends(require_read)])
def listing(request: Request) -> dict[str, Any]:
    """Names of the backbone files (``backbones/*.json``)."""
    from labjoint.api.routes.structures import _listing

    return {"backbones": _listing(request, FOLDER, ".json")}


@router.get("/{name}", responses=errors_doc(), summary="A stored backbone file",
            dependencies=[Depends(require_read)])
def stored(request: Request, name: str = Path(pattern=RUN_NAME)) -> dict[str, Any]:
    """The backbone file: {"format", "mode", "backbones": [{"sensor", "quantity",
    "amplitude_units", "notes", "points"}]}."""
    from labjoint.api.routes.structures import named_file
    from labjoint.signal.backbone import load_backbones

    bs, mode = load_backbones(named_file(request, FOLDER, name, ".json"))
    return {"format": FORMAT, "mode": mode, "backbones": [b.to_dict() for b in bs]}
