"""The CLI's plausibility limits (the rig config's [plausibility] table, --max-displacement)
and the measurement flags' text lines, shared by analyze, fit, diagnose and ladder."""

from __future__ import annotations

import argparse
from typing import Any

from labjoint.errors import InputError


def plausibility(args: argparse.Namespace) -> Any:
    """The plausibility limits (labjoint.identify.plausible.Plausibility): the rig config's
    [plausibility] table when --config is given, --max-displacement over it; None when
    neither is given (the pipeline's defaults)."""
    from labjoint.identify.plausible import Plausibility

    table: dict[str, Any] = {}
    if getattr(args, "config", None):
        from labjoint.config import load_config

        table = load_config(args.config).plausibility.model_dump()
    cap = getattr(args, "max_displacement", None)
    if cap is not None:
        if not cap > 0:
            raise InputError(f"must be a positive amplitude in m, got {cap}", field="max_displacement")
        table["max_displacement_amplitude_m"] = float(cap)
    if not any(v is not None for v in table.values()):
        return None
    return Plausibility.from_mapping(table, getattr(args, "config", None) or "")


def print_flags(res: dict[str, Any]) -> None:
    """One warning line per measurement flag (the text output's counterpart of the JSON's
    ``measurement_flags``, :mod:`labjoint.compare.flags`)."""
    for f in res.get("measurement_flags") or []:
        print(f"warning: run {f['run']}: {f['message']}")
