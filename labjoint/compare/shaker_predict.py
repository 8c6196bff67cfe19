"""A saved joint model driven by a record's voltage through the shaker (issue 29 item 3):
``labjoint predict MODEL.json RECORD --shaker S.toml``.

The model file is a force-input equation of motion (``labjoint fit --error simulation
--out``: inertia and the joint's effects); the ``[shaker]`` table of S.toml gives the
whole shaker (:mod:`labjoint.models.shaker`). The simulator integrates the coil with the
mass (:func:`labjoint.models.simulate.simulate_states`), so the prediction holds both
the response per volt, in the response channel's own quantity (displacement, velocity
or acceleration, from the states: nothing measured is integrated), and the force on the
structure per the armature equation (S2), compared with a measured force when the
record has one. A record driven by a force is refused: the shaker is not between.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from labjoint.compare.model_file import load_model
from labjoint.errors import InputError
from labjoint.models.shaker import Shaker, shaker_table
from labjoint.models.simulate import shaker_outputs, simulate_states
from labjoint.storage.reader import read_channels

MOTION = ("displacement", "velocity", "acceleration")
REST = 1e-2         # a response whose first sample is below this fraction of its peak starts at rest


def load_shaker(path: str | Path) -> Shaker:
    """The complete shaker of a file's ``[shaker]`` table (a missing parameter named)."""
    t = shaker_table(path)
    if not t:
        raise InputError("no [shaker] table", file=str(path), field="shaker")
    return Shaker.from_mapping(t, str(path))


def predict_shaker(model_path: str | Path, record: str | Path, shaker_path: str | Path,
                   warmup: str | float = "auto", response: str | None = None) -> dict[str, Any]:
    """The model through the shaker on the record: per channel NRMSE over the judged
    samples (the response in its quantity; the force when measured) and the series."""
    model, vals, substeps = load_model(model_path)
    sh = load_shaker(shaker_path)
    rec = read_channels(record)
    drives = rec.drives
    volts = [c for c in drives if c.quantity == "voltage"]
    if not volts:
        what = ", ".join(f"{c.name} ({c.quantity})" for c in drives) or "none"
        raise InputError(f"--shaker takes a record driven by a voltage; its drives: {what} (a force "
                         "drive needs no shaker: predict without --shaker)", file=str(record),
                         field="drive")
    u = np.asarray(volts[0].samples, float)
    motion = [c for c in rec.responses if c.quantity in MOTION]
    if response is not None:
        ch = rec.channel(response)
        if ch.quantity not in MOTION:
            raise InputError(f"channel {response!r} is a {ch.quantity}, not a displacement, velocity "
                             "or acceleration", file=str(record), field=response)
    elif motion:
        ch = motion[0]
    else:
        raise InputError("no response channel of displacement, velocity or acceleration",
                         file=str(record), field="responses")
    fs = float(rec.sample_rate_hz)
    start = _judged_from(np.asarray(ch.samples, float), fs, warmup, record)
    out = shaker_outputs(simulate_states(model, vals, u, fs, substeps=substeps, shaker=sh), sh, u)
    if not all(np.all(np.isfinite(v)) for v in out.values()):
        raise InputError("the model diverges through the shaker on this record", file=str(record),
                         field="model")
    chans = {ch.name: _compare(ch.quantity, np.asarray(ch.samples, float), out[ch.quantity], start)}
    forces = [c for c in rec.channels.values() if c.quantity == "force"]
    if forces:
        chans[forces[0].name] = _compare("force", np.asarray(forces[0].samples, float), out["force"], start)
    else:
        chans["force (model)"] = {"quantity": "force", "nrmse": None, "measured": None,
                                  "model": out["force"][start:].tolist(),
                                  "rms_n": float(np.sqrt(np.mean(out["force"][start:] ** 2)))}
    return {"model": str(model_path), "record": str(record), "kind": "shaker", "shaker": sh.to_dict(),
            "drive": volts[0].name, "response": ch.name, "nrmse": chans[ch.name]["nrmse"],
            "warmup_s": start / fs, "sample_rate_hz": fs, "channels": chans}


def _compare(quantity: str, measured: np.ndarray, model: np.ndarray, start: int) -> dict[str, Any]:
    y, p = measured[start:], model[start:]
    den = float(np.mean(y**2))
    return {"quantity": quantity, "nrmse": float(np.sqrt(np.mean((p - y) ** 2) / den)) if den > 0 else None,
            "measured": y.tolist(), "model": p.tolist()}


def _judged_from(u: np.ndarray, fs: float, warmup: str | float, record: Any) -> int:
    """First judged sample: after ``warmup`` seconds; "auto": 0 when the response ``u``
    starts at rest (the simulation starts at rest too), else refused (give --warmup)."""
    if warmup == "auto":
        peak = float(np.max(np.abs(u))) if u.size else 0.0
        if peak > 0 and abs(u[0]) > REST * peak:
            raise InputError("the response does not start at rest, and the simulation does: give "
                             "--warmup SECONDS (a few decay times of the lowest mode)",
                             file=str(record), field="warmup")
        return 0
    try:
        w = float(warmup)
    except (TypeError, ValueError):
        raise InputError(f"must be 'auto' or seconds, got {warmup!r}", field="warmup") from None
    n = int(round(w * fs))
    if not 0 <= n < u.size - 10:
        raise InputError(f"{w:g} s leaves fewer than 10 samples of the record", field="warmup")
    return n
