"""The record files a command is given: run files stay paths (streamed), CSV records are read."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from labjoint.errors import InputError


def load_runs(paths: list[str]) -> list[Any]:
    """Run files as paths (streamed by the pipelines); CSV records in the import format
    as in-memory runs (:func:`labjoint.storage.read_any`). A missing file is named."""
    from labjoint.storage import is_csv, read_any

    out: list[Any] = []
    for p in paths:
        path = Path(p)
        if not path.exists():
            raise InputError("no such file", file=p)
        out.append(read_any(path) if is_csv(path) else path)
    return out
