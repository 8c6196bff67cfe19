"""Reprocess catalogued runs: plan what to compute, run the tasks, record the results.

The engine-agnostic part of ``labjoint reprocess``. :func:`plan_reprocess` decides from
the catalog alone (no run file is opened) which runs need the pipeline: a run whose result
for the same pipeline and options is ``complete`` with the current pipeline version
(:func:`~labjoint.batch.pipelines.pipeline_version`) is skipped; anything else (no result,
a failed one, another version) is computed. A run file that is gone is reported at once.
:func:`execute` runs the tasks on a runner (:class:`SerialRunner` here, a Dask client's
in :mod:`labjoint.batch.cluster`) and records each result in the catalog's ``results``
table as its task ends. A result is recorded ``complete`` only after its processed group
was written, so a reprocess that is interrupted resumes where it stopped.

Model pipelines (fit, diagnose, ladder) take groups of runs: ``group_by`` names a
catalog column (or metadata key), one task per value; the group's members are part of its
options, and each member run gets the group's result row.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

from labjoint.batch.pipelines import get_pipeline, pipeline_version
from labjoint.batch.tasks import Task, named, run_task
from labjoint.errors import InputError
from labjoint.storage.results import ResultRow, Results, options_hash, options_json

Progress = Callable[[int, int, str], None]


@dataclass
class Plan:
    """What a reprocess will do: the tasks to run, runs skipped and runs already failed."""

    pipeline: str
    version: str
    tasks: list[Task] = field(default_factory=list)
    skipped: list[dict[str, Any]] = field(default_factory=list)
    failed: list[dict[str, Any]] = field(default_factory=list)


def _group_value(rec: Any, group_by: str) -> Any:
    v = getattr(rec, group_by, None) if group_by in rec.__dataclass_fields__ else None
    if v is None:
        v = rec.metadata.get(group_by)
    return v


def groups_of(records: list[Any], group_by: str | None) -> dict[str, list[Any]]:
    """Records by the text of their ``group_by`` value (all in one group without it)."""
    if not group_by:
        return {"all": list(records)}
    out: dict[str, list[Any]] = {}
    for rec in records:
        out.setdefault(f"{group_by}={_group_value(rec, group_by)}", []).append(rec)
    return out


def plan_reprocess(results: Results, records: list[Any], pipeline: str,
                   options: dict[str, Any] | None = None, *, group_by: str | None = None,
                   force: bool = False, spread: bool = False) -> Plan:
    """The plan of a reprocess of ``records`` (catalog rows) with ``pipeline``."""
    pipe = get_pipeline(pipeline)
    options = dict(options or {})
    options_json(options)                     # not JSON: named before anything runs
    if not records:
        raise InputError("the query matches no runs", field="query")
    if group_by and not pipe.grouped:
        raise InputError(f"--group-by applies to fit, diagnose and ladder, not {pipeline}",
                         field="group_by")
    version = pipeline_version(pipeline)
    plan = Plan(pipeline, version)
    if not pipe.grouped:
        oh = options_hash(options)
        done = results.of(pipeline, oh)
        for rec in records:
            if not force and done.get(rec.name) == ("complete", version):
                plan.skipped.append({"run": rec.name, "status": "skipped", "version": version})
            elif not Path(rec.path).is_file():
                plan.failed.append(_gone(rec))
            else:
                plan.tasks.append(Task(rec.name, pipeline, (rec.name,), (rec.path,), options,
                                       oh, version, spread))
        return plan
    for label, members in groups_of(records, group_by).items():
        members = sorted(members, key=lambda r: r.name)
        names = tuple(r.name for r in members)
        opts = {**options, "group_by": group_by, "group": label, "runs": list(names)}
        oh = options_hash(opts)
        done = results.of(pipeline, oh)
        gone = [r for r in members if not Path(r.path).is_file()]
        if not force and all(done.get(n) == ("complete", version) for n in names):
            plan.skipped += [{"run": n, "group": label, "status": "skipped", "version": version}
                             for n in names]
        elif gone:
            plan.failed += [{**_gone(r), "group": label} for r in gone]
        else:
            plan.tasks.append(Task(label, pipeline, names, tuple(r.path for r in members),
                                   opts, oh, version, spread))
    return plan


def _gone(rec: Any) -> dict[str, Any]:
    return {"run": rec.name, "status": "failed",
            "error": f"run {rec.name}: file disappeared ({rec.path})"}


class SerialRunner:
    """Runs tasks one after the other in this process."""

    dashboard_link: str | None = None

    def run(self, tasks: list[Task]) -> Iterator[tuple[Task, dict[str, Any] | BaseException]]:
        for t in tasks:
            try:
                yield t, run_task(t)
            except Exception as exc:  # a bug in a pipeline: reported by run, others go on
                yield t, exc


def execute(plan: Plan, runner: Any, results: Results, progress: Progress | None = None
            ) -> dict[str, Any]:
    """Run the plan's tasks on ``runner`` (``run(tasks)`` yielding (task, result dict or
    exception) as they end), recording each; the report {"pipeline", "version",
    "computed", "skipped", "not_applicable", "failed", "runs": [...]}: a run the pipeline
    does not handle (:class:`~labjoint.errors.NotApplicable`: not a steady sine, no
    displacement sensor) is "not_applicable", not "failed"."""
    rows: list[dict[str, Any]] = list(plan.skipped) + list(plan.failed)
    total, done = len(plan.tasks), 0
    stream = runner.run(plan.tasks)
    try:
        for task, res in stream:
            rows += record_task(results, task, res)
            done += 1
            if progress is not None:
                progress(done, total, task.key)
    finally:
        close = getattr(stream, "close", None)
        if close is not None:
            close()                      # a cancelled reprocess starts no more tasks
    order = {n: i for i, n in enumerate(_names(plan))}
    rows.sort(key=lambda r: order.get(r["run"], len(order)))
    count = {s: sum(1 for r in rows if r["status"] == s)
             for s in ("computed", "skipped", "not_applicable", "failed")}
    return {"pipeline": plan.pipeline, "version": plan.version, **count, "runs": rows}


def _names(plan: Plan) -> Iterable[str]:
    seen = [r["run"] for r in plan.skipped + plan.failed]
    for t in plan.tasks:
        seen += list(t.names)
    return sorted(seen)


def record_task(results: Results, task: Task, res: dict[str, Any] | BaseException
                ) -> list[dict[str, Any]]:
    """Record a task's outcome for each of its runs; the report rows."""
    if isinstance(res, BaseException):
        res = {"status": "failed", "summary": {}, "input_sha256": {},
               "error": named(task, _describe(res)), "version": task.version}
    rows = []
    for name in task.names:
        results.record(ResultRow(
            name, task.pipeline, task.options_hash, task.version, res["status"],
            computed_at=res.get("computed_at", ""),
            labjoint_version=res.get("labjoint_version", "") or ResultRow.labjoint_version,
            input_sha256=res["input_sha256"].get(name, ""), options=task.options,
            summary=res["summary"], error=res["error"]))
        row = {"run": name, "status": "computed" if res["status"] == "complete" else
               "not_applicable" if res.get("not_applicable") else "failed",
               "version": task.version}
        if len(task.names) > 1 or task.options.get("group"):
            row["group"] = task.key
        if res["status"] == "complete":
            row["summary"] = res["summary"]
        else:
            row["error"] = res["error"]
        rows.append(row)
    return rows


def _describe(exc: BaseException) -> str:
    """A task's exception as a line: a worker lost twice is said so."""
    name = type(exc).__name__
    if name == "KilledWorker":
        return ("the worker running it died, and again on the retry (KilledWorker): "
                "out of memory, or a crash in native code")
    return f"{name}: {exc}"
