"""Ladders saved beside the raw data, where the REST service and the web page read them.

A ladder is written to every HDF5 run file of its set as the processed group
``model_ladder_<key>`` (``/entry/processed/model_ladder_<key>``, NXprocess; key: the
ladder's 12-hex-digit id of runs, start model, mode and split, so recomputing the same
question replaces the earlier answer). The group holds the ladder as JSON text (attribute
``ladder``) and, as arrays, each step's NRMSE and validation NRMSE and the noise floor.
CSV runs have no run file and are skipped.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from labjoint.compare.jsonsafe import clean
from labjoint.errors import InputError
from labjoint.storage import open_run, write_processed

PREFIX = "model_ladder_"
HDF5_SUFFIXES = (".h5", ".hdf5", ".nxs")


def group_name(key: str) -> str:
    return f"{PREFIX}{key}"


def save_ladder(ladder: dict[str, Any], paths: list[str | Path],
                errors: dict[str, str] | None = None) -> list[str]:
    """Write ``ladder`` (a :meth:`Ladder.to_dict`) into each HDF5 run file; return those
    written. A file that cannot take it (still being written, read-only) is reported in
    ``errors`` (path -> reason) if given, else raises InputError."""
    key = str(ladder["key"])
    steps = ladder["steps"]
    arrays = {"nrmse": np.array([np.nan if s["nrmse"] is None else s["nrmse"] for s in steps]),
              "nrmse_validation": np.array([np.nan if s["nrmse_validation"] is None
                                            else s["nrmse_validation"] for s in steps]),
              "noise_floor": float(np.nan if ladder["noise_floor"] is None else ladder["noise_floor"]),
              "models": "\n".join(s["model"] for s in steps)}
    attrs = {"ladder": json.dumps(clean(ladder), allow_nan=False), "start": ladder["start"],
             "final_model": ladder["final_model"], "adequate": bool(ladder["adequate"])}
    written = []
    for p in paths:
        if p is None or Path(p).suffix.lower() not in HDF5_SUFFIXES:
            continue
        try:
            write_processed(p, group_name(key), arrays, attrs, units={"nrmse": "", "noise_floor": ""})
        except InputError as exc:
            if errors is None:
                raise
            errors[str(p)] = exc.message
            continue
        written.append(str(p))
    return written


def load_ladders(path: str | Path) -> list[dict[str, Any]]:
    """Every ladder saved in run file ``path`` (newest write of each key), as dicts."""
    out = []
    with open_run(path) as rf:
        for name in rf.processed_names:
            if name.startswith(PREFIX):
                out.append(_parse(rf.processed(name)[1], path, name))
    return out


def load_ladder(path: str | Path, key: str) -> dict[str, Any]:
    """The ladder ``key`` saved in run file ``path`` (InputError naming both if absent)."""
    with open_run(path) as rf:
        name = group_name(key)
        if name not in rf.processed_names:
            raise InputError(f"no ladder '{key}' in this run file", file=str(path), field="key")
        return _parse(rf.processed(name)[1], path, name)


def _parse(attrs: dict[str, Any], path: str | Path, name: str) -> dict[str, Any]:
    try:
        return json.loads(attrs["ladder"])
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"damaged ladder group {name}: {exc}", file=str(path), field=name) from None
