"""The modal kind on the REST model routes (issue 29 item 5): the options of a structure
nobody can describe, checked before a job is queued, and the measured modes resolved
inside the data directory.

``options.modal`` is either the name of a file in the data directory's ``frf/`` folder (a
stored FRF set, whose modes are found as ``labjoint modes`` finds them, in
``options.modal_band`` when given, when the job runs; or a modes file, the JSON of
``labjoint modes --json``) or the modes JSON itself, uploaded in the request. The other
options are the CLI's (``--between``, ``--responses``, ``--start``, ``--bound``,
``--shaker`` as the ``[shaker]`` table's fields, ``--drive-point``, ``--modal-mass``):
a bad one answers 422 naming ``options.<key>`` (``options.shaker.<field>``,
``options.bounds.<name>``). A fit with ``options.save_as`` stores the fitted model
(``labjoint.modalmodel/1``, as ``fit --out``) as ``models/<save_as>.json`` for
``POST /models/predict``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, Field

from labjoint.api.resolve import find_named
from labjoint.api.schemas import RUN_NAME
from labjoint.errors import InputError

FRFSETS, MODELS = "frf", "models"
Name = Annotated[str, Field(pattern=RUN_NAME)]
ParamName = Annotated[str, Field(max_length=100, pattern=r"^[a-z][a-z0-9_]*\.[A-Za-z0-9_.]+$")]
Finite = Annotated[float, Field(allow_inf_nan=False)]
Hz = Annotated[float, Field(ge=0, le=1e6, allow_inf_nan=False)]
#: options that only the modal kind takes
MODAL_ONLY = ("modal_band", "responses", "between", "joint_shape", "start", "bounds", "shaker", "drive_point",
              "modal_mass", "save_as")


class ModalOptions(BaseModel):
    """The modal kind's options of every model job (module docstring)."""

    modal: Name | dict[str, Any] | None = Field(
        None, description="the measured modes: a stored FRF set or modes file (frf/<name>.json) "
                          "or the JSON of `labjoint modes --json` itself")
    modal_band: Annotated[list[Hz], Field(min_length=2, max_length=2)] | None = Field(
        None, description="with a stored FRF set: the band [lo, hi] Hz its modes are found in")
    responses: list[Name] | None = Field(None, min_length=1, max_length=64,
                                         description="the response channels compared (default every "
                                                     "motion channel)")
    between: Annotated[list[Name], Field(min_length=2, max_length=2)] | None = Field(
        None, description="the joint between these two sensors of the modes (else on mode 1)")
    joint_shape: bool | None = Field(None, description="with between: fit the joint's participation "
                                     "in modes 2..N (modal.joint<j>) instead of the sensors' shapes")
    start: dict[ParamName, Finite] | None = Field(None, max_length=100,
                                                  description="starting values {name: value} (SI)")
    bounds: dict[ParamName, Annotated[list[Finite], Field(min_length=2, max_length=2)]] | None = Field(
        None, max_length=100, description="bounds {name: [lo, hi]} (SI); lo = hi holds a parameter")
    shaker: dict[Annotated[str, Field(max_length=60, pattern=r"^[a-z_]+$")], Finite] | None = Field(
        None, max_length=20, description="the electrodynamic shaker between the voltage and the "
        "structure: the [shaker] table's fields (armature and two of Bl, R and modal_mass given)")
    drive_point: Name | None = Field(None, description="with shaker: the sensor it drives")
    modal_mass: float | None = Field(None, gt=0, allow_inf_nan=False,
                                     description="with shaker: mode 1's modal mass at the drive point, kg")
    save_as: Name | None = Field(None, description="fit: store the fitted modal model as "
                                                   "models/<save_as>.json (for POST /models/predict)")


def _named(data_dir: str | Path, folder: str, name: str, what: str, field: str) -> Path:
    """``<folder>/<name>.json`` in the data directory, else InputError (422) naming ``field``."""
    found = find_named(data_dir, folder, name, ".json")
    if found is not None:
        return found
    base = Path(data_dir) / folder
    known = sorted(p.stem for p in base.glob("*.json")) if base.is_dir() else []
    raise InputError(f"no {what} {name!r} in {folder}/; stored: {known[:20]}", field=field)


def _prefixed(exc: InputError, field: str | None = None) -> InputError:
    return InputError(exc.message, field=f"options.{field or exc.field}")


def check_modal(options: dict[str, Any], operation: str, data_dir: str | Path) -> dict[str, Any]:
    """The modal options as compare takes them (``modal``: a ModalBasis, or the stored FRF
    set's path when its modes are found in the job); InputError naming ``options.<key>``."""
    from labjoint.compare.modal_api import _bounds, _starts
    from labjoint.compare.frf_api import is_frfset
    from labjoint.models.shaker import checked_values
    from labjoint.structure.nlmode import basis_from_json, load_basis
    from labjoint.structure.nlmode_pair import differences
    from labjoint.structure.nlmode_shaker import ShakerPath

    out = dict(options)
    if out.get("modal") is None:
        given = [k for k in MODAL_ONLY if out.get(k) is not None]
        if given:
            raise InputError("goes with the modal kind (options.modal: the measured modes)",
                             field=f"options.{given[0]}")
        return out
    if out.get("error") == "simulation":
        raise InputError("the modal kind is judged by its own simulation error; leave error out",
                         field="options.error")
    if out.get("save_as") is not None and operation != "fit":
        raise InputError("a fit stores its model; diagnose and ladder do not", field="options.save_as")
    modal, basis = out["modal"], None
    if isinstance(modal, dict):
        if out.get("modal_band") is not None:
            raise InputError("goes with a stored FRF set", field="options.modal_band")
        try:
            basis = basis_from_json(modal, "options.modal")
        except InputError as exc:
            raise InputError(exc.message, field="options.modal") from None
    else:
        path = _named(data_dir, FRFSETS, modal, "FRF set or modes file", "options.modal")
        if is_frfset(path):
            out["modal"] = path                       # its modes are found in the job
        elif out.get("modal_band") is not None:
            raise InputError(f"{modal!r} is a modes file, not an FRF set", field="options.modal_band")
        else:
            try:
                basis = load_basis(path)
            except InputError as exc:
                raise InputError(f"{modal}: {exc.message}", field="options.modal") from None
    if basis is not None:
        out["modal"] = basis
    try:
        _starts(out.get("start"))
        _bounds(out.get("bounds"))
    except InputError as exc:
        raise InputError(exc.message, field="options." + exc.field.replace("bound.", "bounds.")) from None
    if out.get("joint_shape") and out.get("between") is None:
        raise InputError("goes with options.between", field="options.joint_shape")
    if out.get("shaker") is None:
        for k in ("drive_point", "modal_mass"):
            if out.get(k) is not None:
                raise InputError("goes with a shaker (options.shaker)", field=f"options.{k}")
    else:
        try:
            checked_values(out["shaker"], "options.shaker")
        except InputError as exc:
            raise _prefixed(exc) from None
        if not out.get("drive_point"):
            raise InputError("names the sensor the shaker drives", field="options.drive_point")
    if basis is not None:
        try:
            if out.get("between") is not None:
                differences(basis, *out["between"])
            if out.get("shaker") is not None:
                ShakerPath.of(out["shaker"], out["drive_point"], basis, out.get("modal_mass"))
        except InputError as exc:
            raise _prefixed(exc, "between" if exc.field == "joint.between" else None) from None
    return out


def modes_of(path: Path, band: list[float] | None) -> Any:
    """The measured modes of a stored FRF set (``labjoint modes`` on it, lowest level)."""
    from labjoint.identify.spectral import SpectralOptions, modes_levels
    from labjoint.structure.nlmode import basis_from_json

    opts = SpectralOptions(band=None if band is None else f"{band[0]}:{band[1]}")
    return basis_from_json({"levels": modes_levels([str(path)], opts)}, f"frf/{path.name}")


def run_modal(operation: str, paths: list[str], model: str, kw: dict[str, Any],
              data_dir: str | Path) -> dict[str, Any]:
    """A modal model job: ``compare.<operation>`` with the modes resolved; a fit with
    ``save_as`` stores its model (written whole, or nothing when not finite)."""
    import labjoint.compare as compare
    from labjoint.compare.api import _measured, fit_report
    from labjoint.compare.jsonsafe import clean
    from labjoint.compare.modal_api import save_modal

    kw = dict(kw)
    if isinstance(kw.get("modal"), Path):
        kw["modal"] = modes_of(kw["modal"], kw.get("modal_band"))
    kw.pop("modal_band", None)
    save_as = kw.pop("save_as", None)
    if operation != "fit" or save_as is None:
        res = getattr(compare, operation)(paths, model, **kw)
        return res if isinstance(res, dict) else res.to_dict()
    report = fit_report(paths, model, **kw)
    folder = Path(data_dir) / MODELS
    folder.mkdir(parents=True, exist_ok=True)
    save_modal(report.fit, report.evaluation.runs_measured(), folder / f"{save_as}.json")
    res = clean(_measured(report.to_dict(full=bool(kw.get("full"))), report.evaluation.runs_measured()))
    res["saved"] = f"{MODELS}/{save_as}.json"
    return res


def predict_runs(data_dir: str | Path, model_name: str, runs: dict[str, str], full: bool) -> dict[str, Any]:
    """The stored modal model ``models/<model_name>.json`` on each run (``labjoint predict``'s
    JSON per run, named by run; the series only with ``full``)."""
    from labjoint.compare.jsonsafe import clean
    from labjoint.compare.modal_api import predict_modal

    path = _named(data_dir, MODELS, model_name, "modal model", "model_file")
    out = []
    for name, p in runs.items():
        res = predict_modal(path, p)
        res["record"] = name
        if not full:
            for v in res["channels"].values():
                v.pop("measured"), v.pop("model")
            res.pop("force_on_structure_n", None)
        out.append(res)
    return clean({"model_file": f"{MODELS}/{path.name}", "runs": out})


__all__ = ["MODAL_ONLY", "ModalOptions", "check_modal", "predict_runs", "run_modal"]
