"""One reprocess task: run a pipeline on run files where they are; return a small dict.

A task receives run names and paths (never the records: the worker reads the files
itself, on the shared filesystem) and returns a few hundred bytes: the status, the
summary, each input file's sha256 as the pipeline read it, and the error of a failed run.
A bad run (missing file, not a sine, a missing channel, a damaged file: h5py's OSError or
RuntimeError) is a ``failed`` result naming its file, not an exception; anything else (a
bug, a dying worker) propagates, so the engine retries it. A worker whose code gives
another pipeline version than the plan's refuses the task.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from labjoint import __version__
from labjoint.batch.pipelines import get_pipeline, pipeline_version
from labjoint.documents import utc_now
from labjoint.errors import LabjointError, NotApplicable
from labjoint.storage.checksum import raw_sha256


@dataclass(frozen=True)
class Task:
    """The work of one task: a pipeline on runs (one, or a group), with options."""

    key: str
    pipeline: str
    names: tuple[str, ...]
    paths: tuple[str, ...]
    options: dict[str, Any]
    options_hash: str
    version: str
    spread: bool = field(default=False, compare=False)


def run_task(task: Task, executor: Any = None, threads: bool = True) -> dict[str, Any]:
    """Run ``task`` here; the small result dict (see the module docstring).

    ``threads=False``: each record's pipeline stays in this thread (a worker of a
    cluster with a worker per core; the record's own helper threads would only compete
    with the other workers for the cores)."""
    out: dict[str, Any] = {"key": task.key, "runs": list(task.names), "status": "failed",
                           "summary": {}, "input_sha256": {}, "error": "",
                           "version": task.version, "labjoint_version": __version__}
    here = pipeline_version(task.pipeline)
    if here != task.version:          # a worker with other code would mislabel its result
        out["error"] = (f"this worker runs {task.pipeline} version {here}, the reprocess "
                        f"planned {task.version}: install the same labjoint on every worker")
        return out
    try:
        for name, p in zip(task.names, task.paths):
            if not Path(p).is_file():
                out["error"] = f"run {name}: file disappeared ({p})"
                return out
            out["input_sha256"][name] = raw_sha256(p)
        opts = {**task.options, "pipeline": task.pipeline, "options_hash": task.options_hash,
                "threads": threads}
        pipe = get_pipeline(task.pipeline)
        out["summary"] = pipe.run([Path(p) for p in task.paths], opts, executor)
    except LabjointError as exc:
        out["error"] = named(task, str(exc))
        if isinstance(exc, NotApplicable):       # kept with the result: not a failure
            out["not_applicable"] = True
            out["summary"] = {"not_applicable": True}
        return out
    except (OSError, RuntimeError) as exc:   # h5py on a damaged file: its input, not a bug
        out["error"] = named(task, f"{type(exc).__name__}: {_line(exc)}")
        return out
    out["status"] = "complete"
    out["computed_at"] = utc_now()
    return out



def _line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else ""


def named(task: Task, message: str) -> str:
    """``message`` with the task's run files named, unless it names one already."""
    if any(p in message for p in task.paths):
        return message
    where = ", ".join(f"run {n} ({p})" for n, p in zip(task.names, task.paths))
    return f"{where}: {message}"
