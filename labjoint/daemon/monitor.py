"""What the daemon watches while a plan runs, without holding any samples.

- :class:`WatchedGenerator` wraps the generator driver and remembers the last settings
  and output state commanded or read back (so ``status()`` never talks to the
  instrument, and every "output OFF" is time-stamped);
- :class:`RunTracker` is a document callback that counts samples and checks the
  sample counter's continuity (every gap is kept, logged and reported on the job);
- :func:`observe` passes a plan's messages through to the engine, telling the tracker
  which run is next, so progress can be computed;
- :func:`job_outcome` turns how a plan ended into the job's status.
"""

from __future__ import annotations

import logging
import math
import threading
from dataclasses import asdict
from typing import Any, Callable, Generator, Mapping, Sequence

from labjoint.documents import Block, RunStart, RunStop
from labjoint.acquisition.messages import PlanResult
from labjoint.acquisition.messages import (Configure, LoadWaveform, Measure, Measurement, Record,
                                           SteadyResult, WaitSteady)
from labjoint.acquisition.plans import dry_run, load_plan
from labjoint.daemon.queue import utc_now
from labjoint.hardware.interfaces import GeneratorSettings, SignalGenerator

log = logging.getLogger(__name__)

#: Gaps kept per job (a broken DAQ could report millions); the count goes on.
MAX_GAPS_KEPT = 100


class WatchedGenerator(SignalGenerator):
    """A :class:`SignalGenerator` that forwards every call to ``inner`` and records the
    outcome; ``output`` is None when the last switch failed (state unknown)."""

    def __init__(self, inner: SignalGenerator) -> None:
        self.inner = inner
        self.settings: GeneratorSettings | None = None
        self.output: bool | None = None
        self.output_off_at: str | None = None
        self.last_error: str | None = None
        self._lock = threading.RLock()

    def identify(self) -> str:
        return self.inner.identify()

    def apply(self, frequency_hz: float, amplitude_vpp: float, offset_v: float = 0.0) -> GeneratorSettings:
        with self._lock:
            rb = self._call(self.inner.apply, frequency_hz, amplitude_vpp, offset_v)
            self.settings = rb
            return rb

    def set_amplitude(self, amplitude_vpp: float) -> GeneratorSettings:
        with self._lock:
            self.settings = self._call(self.inner.set_amplitude, amplitude_vpp)
            return self.settings

    def set_output(self, on: bool) -> None:
        with self._lock:
            try:
                self._call(self.inner.set_output, on)
            except BaseException:
                self.output = None
                raise
            self.output = bool(on)
            if not on:
                self.output_off_at = utc_now()

    def load_waveform(self, points: Any) -> int:
        with self._lock:
            return self._call(self.inner.load_waveform, points)

    def apply_waveform(self, frequency_hz: float, amplitude_vpp: float,
                       offset_v: float = 0.0) -> GeneratorSettings:
        with self._lock:
            rb = self._call(self.inner.apply_waveform, frequency_hz, amplitude_vpp, offset_v)
            self.settings = rb
            return rb

    def waveform(self) -> Any:
        return self.inner.waveform()

    def read_settings(self) -> GeneratorSettings:
        with self._lock:
            s = self._call(self.inner.read_settings)
            self.settings, self.output = s, bool(s.output)
            return s

    def close(self) -> None:
        with self._lock:
            self._call(self.inner.close)
            self.output = False
            self.output_off_at = utc_now()

    def _call(self, fn: Callable[..., Any], *args: Any) -> Any:
        try:
            return fn(*args)
        except Exception as exc:
            self.last_error = f"{type(exc).__name__}: {exc}"
            raise

    def snapshot(self) -> dict[str, Any]:
        """Last known settings and output state (JSON-ready)."""
        d: dict[str, Any] = {} if self.settings is None else asdict(self.settings)
        d["output"] = self.output
        d["output_off_at"] = self.output_off_at
        return d


class RunTracker:
    """Document callback: per-run sample counts and sample-counter continuity, in O(1)
    memory (no samples are kept)."""

    def __init__(self) -> None:
        self.runs: list[str] = []
        self.run: str | None = None
        self.run_status: str | None = None
        self.samples = 0
        self.total_samples = 0
        self.gaps: list[dict[str, Any]] = []
        self.n_gaps = 0
        self.records_done = 0
        self.record_target: int | None = None  # samples the running Record asks for
        self.unconverged: list[str] = []   # runs recorded off their force target (step_sine)
        self._expected = 0
        self._uid: str | None = None

    def __call__(self, name: str, doc: Any) -> None:
        if name == "start" and isinstance(doc, RunStart):
            self.run, self._uid, self.samples, self._expected = doc.name, doc.uid, 0, 0
            self.run_status = "running"
            self.runs.append(doc.name)
            md = doc.metadata or {}
            if md.get("force_converged") is False:
                self.unconverged.append(
                    f"{doc.name} ({_num(md.get('measured_force_n'))} N of "
                    f"{_num(md.get('target_force_n'))} N)")
        elif name == "block" and isinstance(doc, Block) and doc.uid == self._uid:
            first, n = int(doc.first_sample), int(doc.volts.shape[1])
            if first != self._expected:
                self.n_gaps += 1
                log.warning("run %s: sample counter expected %d, got %d", self.run, self._expected, first)
                if len(self.gaps) < MAX_GAPS_KEPT:
                    self.gaps.append({"run": self.run, "expected": self._expected, "got": first})
            self._expected = first + n
            self.samples += n
            self.total_samples += n
        elif name == "stop" and isinstance(doc, RunStop) and doc.uid == self._uid:
            self.run_status = doc.status
            self.records_done += 1
            self.record_target = None

    def progress(self, expected_records: int | None) -> float:
        """Fraction of the plan done: finished runs plus the running one's share."""
        part = 0.0
        if self.run_status == "running" and self.record_target:
            part = min(1.0, self.samples / self.record_target)
        if expected_records:
            return min(1.0, (self.records_done + part) / expected_records)
        return (self.records_done + part) / (self.records_done + 1.0)


def observe(plan: Generator, tracker: RunTracker, sample_rate_hz: float) -> Generator:
    """Forward ``plan``'s messages and the engine's answers unchanged; note on the
    tracker how many samples each Record asks for (as the engine computes it)."""
    frequency = math.nan
    answer = None
    try:
        while True:
            try:
                msg = plan.send(answer)
            except StopIteration:
                return
            if isinstance(msg, (Configure, LoadWaveform)):
                frequency = msg.frequency_hz
            elif isinstance(msg, Record):
                n = (msg.n_cycles * sample_rate_hz / frequency if msg.n_cycles is not None
                     else msg.duration_s * sample_rate_hz)
                tracker.record_target = int(math.ceil(n)) if math.isfinite(n) else None
            answer = yield msg
    finally:
        plan.close()


def expected_records(plan: Mapping[str, Any]) -> int | None:
    """How many runs the plan will record, by a dry run with a stand-in responder
    (steady state reached at once; closed-loop force on target); None if unknown."""
    target = float(plan.get("force_amplitude_n", 1.0) or 1.0)

    def respond(msg: Any) -> Any:
        if isinstance(msg, WaitSteady):
            return SteadyResult(True, msg.window, 0.0)
        if isinstance(msg, Measure):
            return Measurement(1.0, {"ref": target}, {"ref": 0.0}, "ref")
        return None

    try:
        return sum(isinstance(m, Record) for m in dry_run(load_plan(dict(plan)), respond))
    except Exception:  # progress is a nicety: never fail a job over it
        return None


def _num(v: Any) -> str:
    try:
        return f"{float(v):.4g}"
    except (TypeError, ValueError):
        return "?"


def job_outcome(result: PlanResult, n_gaps: int = 0, cancelled: bool = False,
                unconverged: Sequence[str] = ()) -> tuple[str, str, str | None]:
    """(job status, message, error) from how the plan ended. A plan that ran to its end
    but recorded runs whose force never reached its target (``unconverged``, step_sine's
    ``force_converged: false``) did not do what it was asked: "failed", naming them.

    >>> job_outcome(PlanResult("limit", "force 30 N over max_force_n"))
    ('failed', 'safety limit: force 30 N over max_force_n', 'limit: force 30 N over max_force_n')
    >>> job_outcome(PlanResult("complete"), unconverged=["s_000 (12 N of 50 N)"])[2]
    'force did not reach its target in 1 run(s): s_000 (12 N of 50 N)'
    """
    n = len(result.runs)
    gaps = f"; {n_gaps} sample-counter gap(s)" if n_gaps else ""
    if result.status == "complete" and unconverged:
        why = (f"force did not reach its target in {len(unconverged)} run(s): "
               + ", ".join(unconverged))
        return "failed", f"{n} run(s) recorded, but the {why}{gaps}", why
    if result.status == "complete":
        return "done", f"{n} run(s) recorded{gaps}", None
    if result.status == "limit":
        return "failed", f"safety limit: {result.reason}{gaps}", f"limit: {result.reason}"
    if result.status == "aborted":
        if cancelled:
            return "cancelled", f"cancelled during the run; {n} run(s) kept{gaps}", None
        return "aborted", f"aborted: {result.reason}{gaps}", result.reason
    return "failed", f"failed: {result.reason}{gaps}", result.reason
