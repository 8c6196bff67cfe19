"""Backbones: frequency and damping ratio against amplitude from catalogued runs.

``POST /backbones`` names runs (phase_resonance levels and their ringdown, or step_sine
runs); they are resolved through the catalog (:class:`~labjoint.api.resolve.RunResolver`,
nothing a client sends becomes a path) and analysed at once by
:func:`labjoint.identify.backbone.measured_backbones`: the answer is the CLI's
``labjoint backbone --json`` without the model (``points``, ``notes``, ``sensor``).
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Request
from pydantic import BaseModel, ConfigDict, Field

from labjoint.api.auth import require_control
from labjoint.api.errors import errors_doc
from labjoint.api.schemas import RUN_NAME
from labjoint.errors import InputError

router = APIRouter(prefix="/backbones", tags=["backbones"])
Name = Annotated[str, Field(pattern=RUN_NAME)]


class BackboneRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    runs: list[Name] = Field(min_length=1, max_length=200)
    modal_mass_kg: float | None = Field(None, gt=0, le=1e6, allow_inf_nan=False)
    sensor: Name | None = None


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


@router.post("", response_model=BackboneOut, responses=errors_doc(), summary="Backbones of runs",
             dependencies=[Depends(require_control)])
def backbones(request: Request, body: BackboneRequest) -> dict[str, Any]:
    """Frequency and damping ratio against the fundamental's displacement amplitude at the
    response sensor, with uncertainties, by method (phase resonance, force-corrected
    ringdown, step sine)."""
    from labjoint.identify.backbone import measured_backbones

    res = request.app.state.resolver
    paths = [res.path(n) for n in dict.fromkeys(body.runs)]
    try:
        meas = measured_backbones(paths, body.sensor, body.modal_mass_kg)
    except InputError as exc:          # the message without the server's paths
        raise InputError(exc.message, field=exc.field) from None
    return {"points": [p.to_dict(b.amplitude_units) for b in meas for p in b.points],
            "notes": [n for b in meas for n in b.notes], "sensor": meas[0].sensor if meas else None}
