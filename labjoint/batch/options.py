"""A reprocess's pipeline options, checked once for the CLI and the REST service.

The options are what a result is keyed by (their canonical JSON is hashed), so they are
normalised here: defaults filled in, the friction coefficient of ``stickslip`` resolved to
the number the run is processed with (a newly identified coefficient recomputes), the
candidates as one comma-separated string. Bad values raise InputError naming the option.

>>> check_options("analyze", {})
{'force': 'joint'}
>>> check_options("diagnose", {"model": "linear_stiffness", "candidates": ["viscous"]})
{'model': 'linear_stiffness', 'candidates': 'viscous'}
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from labjoint.batch.pipelines import get_pipeline
from labjoint.errors import InputError

KNOWN = {
    "analyze": ("force",),
    "stickslip": ("force", "friction"),
    "fit": ("model", "seed", "kind", "plausibility", "max_displacement"),
    "diagnose": ("model", "seed", "kind", "factor", "alpha", "candidates", "plausibility",
                 "max_displacement"),
    "ladder": ("model", "seed", "kind", "factor", "alpha", "candidates", "max_steps", "plausibility",
               "max_displacement"),
}


def check_options(pipeline: str, options: dict[str, Any] | None,
                  data_dir: str | Path | None = None) -> dict[str, Any]:
    """The normalised options of ``pipeline`` (module docstring)."""
    get_pipeline(pipeline)
    given = {k: v for k, v in (options or {}).items() if v is not None}
    unknown = sorted(set(given) - set(KNOWN[pipeline]))
    if unknown:
        raise InputError(f"not an option of {pipeline}; known: {list(KNOWN[pipeline])}",
                         field=unknown[0])
    out: dict[str, Any] = {}
    if pipeline in ("analyze", "stickslip"):
        force = given.get("force", "joint")
        if force not in ("joint", "reference"):
            raise InputError(f"must be 'joint' or 'reference', got {force!r}", field="force")
        out["force"] = force
    if pipeline == "stickslip":
        out["friction"] = _friction(given.get("friction"), data_dir)
    if pipeline in ("fit", "diagnose", "ladder"):
        out.update(_model_options(given))
    return out


def _friction(mu: Any, data_dir: str | Path | None) -> float:
    if mu is None and data_dir is not None:
        from labjoint.identify.identified import load_identified
        found = load_identified(data_dir, "friction_coefficient")
        mu = None if found is None else found.value
    if mu is None:
        raise InputError("the stick-slip pipeline needs the friction coefficient: give it "
                         "or identify it first (labjoint friction RUN)", field="friction")
    x = _number(mu, "friction")
    if not 0 < x < 10:
        raise InputError(f"must be in (0, 10), got {mu!r}", field="friction")
    return x


def _model_options(given: dict[str, Any]) -> dict[str, Any]:
    from labjoint.models import Model

    model = given.get("model")
    if not model or not isinstance(model, str):
        raise InputError("fit, diagnose and ladder need a model expression (--model EXPR)",
                         field="model")
    out: dict[str, Any] = {"model": Model.parse(model).expr}
    if "seed" in given:
        out["seed"] = _whole(given["seed"], "seed", 0)
    if "kind" in given:
        if given["kind"] not in ("auto", "sine", "record"):
            raise InputError(f"must be auto, sine or record, got {given['kind']!r}", field="kind")
        out["kind"] = given["kind"]
    for key in ("factor", "alpha"):
        if key in given:
            x = _number(given[key], key)
            if not x > 0 or (key == "alpha" and not x < 1):
                raise InputError(f"out of range: {given[key]!r}", field=key)
            out[key] = x
    if "candidates" in given:
        c = given["candidates"]
        names = [s.strip() for s in (c.split(",") if isinstance(c, str) else c) if s.strip()]
        if not names:
            raise InputError("names no effect", field="candidates")
        out["candidates"] = ",".join(names)
    if "max_steps" in given:
        out["max_steps"] = _whole(given["max_steps"], "max_steps", 1)
    if "plausibility" in given or "max_displacement" in given:
        # one table (the rig config's [plausibility] names), the cap over it: what the result is keyed by
        from labjoint.identify.plausible import limits_from

        table = given.get("plausibility") or {}
        if not isinstance(table, dict):
            raise InputError("must be a table of the [plausibility] limits", field="plausibility")
        lim = limits_from(table, given.get("max_displacement"))
        if lim is not None:
            out["plausibility"] = {k: v for k, v in sorted(vars(lim).items())
                                   if k in table or (k == "max_displacement_amplitude_m"
                                                     and given.get("max_displacement") is not None)}
    return out


def _number(v: Any, name: str) -> float:
    if isinstance(v, bool):
        raise InputError(f"must be a number, got {v!r}", field=name)
    try:
        return float(v)
    except (TypeError, ValueError):
        raise InputError(f"must be a number, got {v!r}", field=name) from None


def _whole(v: Any, name: str, lo: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < lo:
        raise InputError(f"must be a whole number >= {lo}, got {v!r}", field=name)
    return v
