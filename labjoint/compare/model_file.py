"""Model files: a simulation-error fit saved as JSON (effect names and parameters, never
code, format ``labjoint-model/1``), read back with its limits checked, and simulated on
a record (``labjoint predict``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from labjoint.compare.output_error import (FORMAT, Prediction, SimulationFit, predict_record,
                                           prepare_records)
from labjoint.compare.sim_start import diverges
from labjoint.errors import InputError
from labjoint.models import Model
from labjoint.models.simulate import DEFAULT_SUBSTEPS


def save_model(fit: SimulationFit, path: str | Path) -> Path:
    """Write the identified model as JSON (effect names and parameters, never code)."""
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(json.dumps(fit.model_dict(), indent=2, allow_nan=False))
    tmp.replace(p)
    return p


def load_model(path: str | Path) -> tuple[Model, dict[str, float], int]:
    """(model, parameter values, substeps) from a file written by :func:`save_model`."""
    p = Path(path)
    try:
        d = json.loads(p.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read the model file: {exc}", file=str(p)) from None
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise InputError(f"not a labjoint model file (format {FORMAT!r} expected)", file=str(p),
                         field="format")
    if not isinstance(d.get("parameters"), dict):
        raise InputError("parameters must be an object {name: {\"value\": ...}}", file=str(p),
                         field="parameters")
    sub = d.get("substeps", DEFAULT_SUBSTEPS)
    if isinstance(sub, bool) or not isinstance(sub, int) or not 1 <= sub <= MAX_FILE_SUBSTEPS:
        raise InputError(f"substeps must be a whole number from 1 to {MAX_FILE_SUBSTEPS}, "
                         f"got {sub!r}", file=str(p), field="substeps")
    try:
        model = Model.parse(d["model"])
        vals = {k: float(v["value"]) for k, v in d["parameters"].items()}
        model.values(vals)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"malformed model file: {exc}", file=str(p)) from None
    except InputError as exc:
        raise InputError(exc.message, file=str(p), field=exc.field) from None
    return model, vals, sub


#: Integration substeps per sample a model file may ask for (the default is 20; each
#: holds two force values per sample in memory, so 1e15 would never be allocated)
MAX_FILE_SUBSTEPS = 10_000


def predict_file(model_path: str | Path, record: Any, *, periodic: bool = False,
                 warmup: str | float = "auto") -> Prediction:
    """Simulate a saved model on a record (run file, CSV or Run), judged after ``warmup``
    (seconds, or "auto": the record kind's rule); a simulation that diverges is refused."""
    model, vals, substeps = load_model(model_path)
    (m,) = prepare_records([record], periodic=periodic, warmup=warmup)
    why = diverges(model, vals, m, periodic, substeps)
    if why:
        raise InputError(f"the model diverges on run '{m.name}': {why}", file=str(model_path),
                         field="model")
    return predict_record(model, vals, m, periodic=periodic, substeps=substeps)
