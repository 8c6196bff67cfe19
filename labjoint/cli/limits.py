"""The CLI's plausibility limits (the rig config's [plausibility] table, --max-displacement)
and the measurement flags' text lines, shared by analyze, fit, diagnose and ladder."""

from __future__ import annotations

import argparse
from typing import Any



def plausibility(args: argparse.Namespace) -> Any:
    """The plausibility limits (labjoint.identify.plausible.Plausibility): the rig config's
    [plausibility] table when --config is given, --max-displacement over it; None when
    neither is given (the pipeline's defaults)."""
    from labjoint.identify.plausible import limits_from

    return limits_from(config_table(args), getattr(args, "max_displacement", None),
                       getattr(args, "config", None) or "")


def config_table(args: argparse.Namespace) -> dict[str, Any]:
    """The rig config's [plausibility] table (--config), {} without one."""
    if not getattr(args, "config", None):
        return {}
    from labjoint.config import load_config

    return {k: v for k, v in load_config(args.config).plausibility.model_dump().items() if v is not None}


def print_flags(res: dict[str, Any]) -> None:
    """One warning line per measurement flag (the text output's counterpart of the JSON's
    ``measurement_flags``, :mod:`labjoint.compare.flags`)."""
    for f in res.get("measurement_flags") or []:
        print(f"warning: {'run ' + f['run'] + ': ' if f.get('run') else ''}{f['message']}")
