"""The identification pipelines as API jobs: options validated up front, runs streamed.

``hysteresis`` runs seed 002's hysteresis-loop pipeline (Eq. 1) on each run as ``labjoint
analyze`` does (:func:`labjoint.identify.analyze.analyze_file`: excitation and clipping
checks, sensor phase), reading it a block at a time, so a long run never sits in memory. ``stick_slip`` runs the stick-slip-boundary pipeline (Eqs. 2-9)
and ``both`` the two side by side with their difference in % (seed 002 Tables 2-4),
through :func:`labjoint.identify.methods.analyze_runs`. A run that cannot be analysed
gets its own error entry; the others still get results.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Iterator, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from labjoint.api.errors import ApiError
from labjoint.api.clipped import friction_flag
from labjoint.api.resolve import RunResolver, roles
from labjoint.errors import InputError
from labjoint.identify.analyze import analyze_blocks, analyze_file
from labjoint.identify.identified import load_identified
from labjoint.identify.stickslip import MAX_FRICTION, MIN_FRICTION
from labjoint.identify.methods import analyze_runs
from labjoint.signal.filter import PAPER_CUTOFF_HZ
from labjoint.storage import RunFile

#: Samples per block when streaming a run through the loop pipeline.
BLOCK_SAMPLES = 1 << 18
METHODS = ("hysteresis", "stick_slip", "both")
Progress = Callable[[float, str], None]


class HysteresisOptions(BaseModel):
    """Options of the hysteresis-loop pipeline (seed 002 Eq. 1)."""

    model_config = ConfigDict(extra="forbid")

    frequency_hz: float | None = Field(None, gt=0, allow_inf_nan=False,
                                       description="default: the run's metadata, else estimated")
    cutoff_hz: float | None = Field(PAPER_CUTOFF_HZ, gt=0, allow_inf_nan=False,
                                    description="zero-phase low-pass cutoff; null: no filter")
    force: Literal["joint", "reference"] = "joint"
    rel_tol: float = Field(0.01, gt=0, lt=1)
    min_cycles: int = Field(3, ge=1, le=100000)


class StickSlipOptions(BaseModel):
    """Options of the stick-slip-boundary pipeline (seed 002 Eqs. 2-9)."""

    model_config = ConfigDict(extra="forbid")

    friction_coefficient: float | None = Field(
        None, ge=MIN_FRICTION, le=MAX_FRICTION, allow_inf_nan=False,
        description="default: the latest friction test in <data_dir>/identified.json")
    shear_stiffness_n_per_m: float | None = Field(
        None, gt=0, allow_inf_nan=False, description="K_t; default: loop slope / 2 (Eq. 9)")
    stiffness: Literal["lsq", "secant"] = "lsq"
    bolt_radius_m: float | None = Field(None, gt=0, allow_inf_nan=False)
    contact_radius_m: float | None = Field(None, gt=0, allow_inf_nan=False)
    inner_radius_m: float | None = Field(None, ge=0, allow_inf_nan=False)
    head_radius_m: float | None = Field(None, gt=0, allow_inf_nan=False)
    torque_to_normal_n_per_nm: float = Field(478.0, gt=0, allow_inf_nan=False)
    cutoff_hz: float | None = Field(PAPER_CUTOFF_HZ, gt=0, allow_inf_nan=False)
    rel_tol: float = Field(0.01, gt=0, lt=1)


def parse_options(method: str, options: dict[str, Any], data_dir: Path) -> dict[str, Any]:
    """Validated options of ``method`` (InputError naming ``options.<key>``); for the
    stick-slip methods the friction coefficient must be given or stored."""
    model = HysteresisOptions if method == "hysteresis" else StickSlipOptions
    if method not in METHODS:
        raise InputError(f"unknown method {method!r}; known: {METHODS}", field="method")
    try:
        opts = model.model_validate(options).model_dump()
    except ValidationError as exc:
        err = exc.errors()[0]
        raise InputError(err["msg"], field=".".join(["options", *map(str, err["loc"])])) from None
    if method != "hysteresis" and opts["friction_coefficient"] is None \
            and load_identified(data_dir, "friction_coefficient") is None:
        raise InputError("the stick-slip method needs the friction coefficient: give "
                         "options.friction_coefficient or run a friction test first",
                         field="options.friction_coefficient")
    return opts


def loop_blocks(rf: RunFile, force: str) -> Iterator[np.ndarray]:
    """(displacement m, joint or reference force N) blocks of an open run, streamed."""
    r = roles(rf)
    disp, fch = r["displacement"], r["force" if force == "joint" else "reference_force"]
    if not disp or not fch:
        raise InputError(f"run has no {'displacement' if not disp else force + ' force'} "
                         f"channel; channels: {rf.channel_names}", file=str(rf.path))
    for blk in rf.iter_blocks(BLOCK_SAMPLES, channels=list(dict.fromkeys(disp + fch))):
        u = blk.data[disp[0]] - blk.data[disp[1]] if len(disp) == 2 else blk.data[disp[0]]
        yield np.stack([u, blk.data[fch[0]]])


def hysteresis_run(rf: RunFile, opts: dict[str, Any]) -> dict[str, Any]:
    """Summary of the loop pipeline on one open run (design.md ``analyze`` fields)."""
    f = opts["frequency_hz"] if opts["frequency_hz"] is not None else rf.frequency_hz
    if rf.status == "running":
        result = analyze_blocks(loop_blocks(rf, opts["force"]), rf.sample_rate_hz, f,
                                opts["cutoff_hz"], rel_tol=opts["rel_tol"],
                                min_cycles=opts["min_cycles"])
    else:       # as `labjoint analyze` runs it: not a steady sine, or clipped: refused
        result = analyze_file(rf.path, force=opts["force"], frequency_hz=f,
                              cutoff_hz=opts["cutoff_hz"], rel_tol=opts["rel_tol"],
                              min_cycles=opts["min_cycles"])
    md = result.metadata
    return {"run": rf.name, **result.summary,
            "torque_nm": rf.metadata.get("torque_nm"),
            "excitation_vpp": rf.metadata.get("excitation_vpp"),
            "n_cycles": md.get("n_cycles"), "cutoff_hz": md.get("cutoff_hz"),
            "warnings": md.get("warnings", [])}


def stick_slip_rows(path: Path, method: str, opts: dict[str, Any],
                    data_dir: Path) -> dict[str, Any]:
    """The stick-slip (or both methods') row of one run file."""
    kw = {k: v for k, v in opts.items() if k not in ("friction_coefficient", "stiffness",
                                                      "shear_stiffness_n_per_m")}
    kw["shear_stiffness"] = opts["shear_stiffness_n_per_m"]
    rows = analyze_runs([path], "stickslip" if method == "stick_slip" else "both",
                        friction=opts["friction_coefficient"], data_dir=data_dir,
                        stiffness=opts["stiffness"], **kw)
    return rows[0]


def run_analysis(resolver: RunResolver, method: str, names: list[str],
                 opts: dict[str, Any], progress: Progress) -> dict[str, Any]:
    """Results of ``method`` on every run in ``names`` (errors per run)."""
    out: list[dict[str, Any]] = []
    for i, name in enumerate(names):
        progress(i / len(names), f"analysing {name}")
        try:
            if method == "hysteresis":
                with resolver.open(name) as rf:
                    out.append(hysteresis_run(rf, opts))
            else:
                out.append(stick_slip_rows(resolver.path(name), method, opts,
                                           resolver.data_dir))
        except (InputError, ApiError) as exc:
            out.append({"run": name, "error": exc.message if isinstance(exc, ApiError)
                        else str(exc)})
            continue
        flag = friction_flag(resolver, out[-1].get("friction_source"))
        if flag:
            out[-1]["friction_flag"] = flag
    progress(1.0, "done")
    return {"method": method, "options": opts, "runs": out}
