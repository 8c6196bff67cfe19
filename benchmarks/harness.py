"""What every benchmark shares: smoke mode, repeats and medians, load average, the JSON line.

The convention (benchmarks/README.md): every ``benchmarks/bench_*.py``

- accepts ``--smoke`` (tiny sizes, a few seconds, same code path; no figure is judged),
- times what it measures as the median of repeats (:meth:`Bench.repeat`), after a
  warm-up call that compiles or loads numba's cached kernels (:meth:`Bench.warm_up`),
- states each figure as a ratio to a reference measured in the same process (real time,
  a peer, a simpler method, scipy) with :meth:`Bench.figure`,
- ends with :meth:`Bench.finish`, which prints the machine's load average before and
  after and, as the last line of stdout, one JSON object (``"benchmark"``, ``"smoke"``,
  ``"figures"``, ``"load_before"``, ``"load_after"``, ``"numba"``, ``"machine"``).

``tests/test_benchmarks_smoke.py`` runs every ``bench_*.py --smoke`` and checks that
JSON line, so a benchmark that no longer runs fails the suite. Nothing here asserts a
time: timings on a shared machine say how busy it was, and the load average printed
beside them is how a reader tells a regression from load.

Scripts import this module as ``benchmarks.harness`` after putting the project root on
``sys.path`` (:func:`project_root`), so ``python benchmarks/bench_x.py`` and ``python -m
benchmarks.bench_x`` both work and the worktree's ``labjoint`` is the one imported.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

ROOT = Path(__file__).resolve().parents[1]
#: 1-minute load average per core above which a figure is flagged as taken on a busy machine
BUSY_PER_CORE = 0.5


def project_root() -> Path:
    """Put the project root first on ``sys.path`` (this checkout's labjoint) and return it."""
    if str(ROOT) not in sys.path[:1]:
        sys.path.insert(0, str(ROOT))
    return ROOT


def loadavg() -> list[float]:
    """The 1, 5 and 15-minute load averages (/proc/loadavg; os.getloadavg elsewhere)."""
    try:
        return [float(x) for x in Path("/proc/loadavg").read_text().split()[:3]]
    except OSError:
        return list(os.getloadavg())


def machine() -> dict[str, Any]:
    """nproc and the CPU model (/proc/cpuinfo), for the README table."""
    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"nproc": os.cpu_count(), "cpu": model or "unknown"}


def parser(doc: str | None) -> argparse.ArgumentParser:
    """An argument parser with the shared ``--smoke`` and ``--repeats`` options."""
    ap = argparse.ArgumentParser(description=(doc or "").strip().splitlines()[0] if doc else None)
    ap.add_argument("--smoke", action="store_true",
                    help="tiny sizes, seconds: checks that the benchmark runs (CI)")
    ap.add_argument("--repeats", type=int, default=None,
                    help="timed repeats per figure (the median is reported)")
    return ap


@dataclass
class Timing:
    """Wall and CPU seconds (this process, all threads) and the result of each repeat."""

    wall: list[float]
    cpu: list[float]
    results: list[Any] = field(default_factory=list)

    @property
    def result(self) -> Any:
        """The last repeat's result."""
        return self.results[-1] if self.results else None

    @property
    def median(self) -> float:
        return statistics.median(self.wall)

    @property
    def cpu_median(self) -> float:
        return statistics.median(self.cpu)

    def median_of(self, values: list[float]) -> float:
        """The median of per-repeat figures (a benchmark that times itself inside)."""
        return statistics.median(values)

    @property
    def best(self) -> float:
        return min(self.wall)

    @property
    def worst(self) -> float:
        return max(self.wall)

    def summary(self) -> dict[str, Any]:
        return {"median_s": self.median, "best_s": self.best, "worst_s": self.worst,
                "cpu_median_s": self.cpu_median, "repeats": len(self.wall)}


@dataclass
class Bench:
    """One benchmark's run: its load average at start, its figures, its JSON line.

    ``repeats`` is the default number of timed repeats (3 in smoke mode: a median
    still needs several).
    """

    name: str
    smoke: bool = False
    repeats: int = 5
    figures: list[dict[str, Any]] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)
    numba: str = "not used"
    load_before: list[float] = field(default_factory=loadavg)
    started: float = field(default_factory=time.perf_counter)

    @classmethod
    def from_args(cls, name: str, args: argparse.Namespace, repeats: int = 5) -> "Bench":
        n = args.repeats if getattr(args, "repeats", None) else (3 if args.smoke else repeats)
        bench = cls(name, smoke=bool(args.smoke), repeats=max(1, int(n)))
        print(f"{name}: load average before {_fmt_load(bench.load_before)}"
              f"{' (smoke: tiny sizes, figures not meaningful)' if bench.smoke else ''}",
              flush=True)
        return bench

    def warm_up(self, fn: Callable[[], Any], what: str = "") -> Any:
        """Call ``fn`` once, untimed, so that numba's kernels are compiled (or loaded
        from their cache) and imports are done before any timing; the output says so."""
        t0 = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t0
        self.numba = (f"compilation excluded: warm-up call{' (' + what + ')' if what else ''} "
                      f"before timing, {dt:.2f} s (kernels with cache=True load from "
                      "__pycache__ after the first run)")
        return out

    def repeat(self, fn: Callable[[], Any], repeats: int | None = None) -> Timing:
        """Time ``fn`` ``repeats`` times (default: the bench's), keeping each result."""
        n = self.repeats if repeats is None else max(1, int(repeats))
        wall, cpu, out = [], [], []
        for _ in range(n):
            c0, t0 = time.process_time(), time.perf_counter()
            out.append(fn())
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        return Timing(wall, cpu, out)

    def figure(self, name: str, ratio: float, reference: str, *, value: float | None = None,
               unit: str = "", target: str = "", timing: Timing | None = None,
               **more: Any) -> dict[str, Any]:
        """Record (and print) one figure: ``ratio`` to ``reference``, measured in this
        process; ``value`` in ``unit`` is the raw quantity (seconds, ms, ...)."""
        fig: dict[str, Any] = {"name": name, "ratio": float(ratio), "reference": reference}
        if value is not None:
            fig.update(value=float(value), unit=unit)
        if target:
            fig["target"] = target
        if timing is not None:
            fig["timing"] = timing.summary()
        fig.update(more)
        self.figures.append(fig)
        shown = f" ({value:.4g} {unit})" if value is not None else ""
        rep = f", median of {len(timing.wall)}" if timing is not None else ""
        tgt = f"; target {target}" if target else ""
        print(f"  {name}: {ratio:.4g}x {reference}{shown}{rep}{tgt}", flush=True)
        return fig

    def finish(self, **extra: Any) -> dict[str, Any]:
        """Print the load after, the numba note and the JSON line (the last line)."""
        after = loadavg()
        cores = os.cpu_count() or 1
        busy = max(self.load_before[0], after[0]) > BUSY_PER_CORE * cores
        out = {"benchmark": self.name, "smoke": self.smoke, "figures": self.figures,
               "load_before": self.load_before, "load_after": after, "busy": busy,
               "numba": self.numba, "machine": machine(),
               "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
               "elapsed_s": time.perf_counter() - self.started, **self.extra, **extra}
        print(f"{self.name}: load average after {_fmt_load(after)} on {cores} CPUs"
              f"{' (BUSY machine: figures below a quiet run are load, not regression)' if busy else ''}")
        print(f"{self.name}: numba {self.numba}")
        print(json.dumps(out, default=_jsonable), flush=True)
        return out


def _fmt_load(load: list[float]) -> str:
    return " ".join(f"{x:.2f}" for x in load)


def _jsonable(x: Any) -> Any:
    try:
        return float(x)
    except (TypeError, ValueError):
        return str(x)
