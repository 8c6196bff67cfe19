"""Units of what the daemon watches: run tracker (counts, continuity, progress), the
expected number of runs of each plan, the generator wrapper, job outcomes."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.documents import Block, RunStart, RunStop
from labjoint.acquisition.messages import PlanResult
from labjoint.acquisition.messages import Configure, Record
from labjoint.acquisition.plans import dwell
from labjoint.config import load_config
from labjoint.daemon.monitor import (RunTracker, WatchedGenerator, expected_records, job_outcome,
                                     observe)
from labjoint.errors import InstrumentTimeout
from labjoint.hardware.interfaces import GeneratorSettings, SignalGenerator

CHANNELS = load_config().daq.specs()


def test_tracker_counts_samples_and_reports_every_counter_jump():
    t = RunTracker()
    t("start", RunStart("u", "r1", CHANNELS, 1000.0))
    t.record_target = 3000
    for first in (0, 1000, 2500):  # 500 samples lost before the third block
        t("block", Block("u", first, np.zeros((4, 1000))))
    assert t.samples == 3000 and t.n_gaps == 1
    assert t.gaps == [{"run": "r1", "expected": 2000, "got": 2500}]
    assert t.progress(2) == pytest.approx(0.5)  # run 1 of 2 full (by sample count)
    t("stop", RunStop("u", "complete"))
    assert t.records_done == 1 and t.run_status == "complete" and t.progress(2) == 0.5
    t("start", RunStart("v", "r2", CHANNELS, 1000.0))
    t("block", Block("v", 0, np.zeros((4, 10))))  # a new run counts from 0 again
    assert t.n_gaps == 1 and t.runs == ["r1", "r2"] and t.total_samples == 3010


def test_observe_forwards_answers_and_sets_the_record_length():
    t = RunTracker()
    gen = observe(dwell(400.0, 2.0, n_cycles=10), t, sample_rate_hz=10000.0)
    msgs = [next(gen)]
    while not isinstance(msgs[-1], Record):
        msgs.append(gen.send("answer"))
    assert isinstance(msgs[0], Configure) and t.record_target == 250  # 10 cycles at 400 Hz
    gen.close()


@pytest.mark.parametrize("plan, n", [
    ({"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 2}, 1),
    ({"plan": "amplitude_sweep", "amplitudes_vpp": [1, 2, 3]}, 3),
    ({"plan": "torque_series"}, 3),
    ({"plan": "step_sine", "frequencies_hz": [380, 400], "force_amplitude_n": 5}, 4),
    ({"plan": "broadband", "n_frequencies": 5}, 5),
    ({"plan": "nope"}, None),
])
def test_expected_records_of_each_plan(plan, n):
    assert expected_records(plan) == n


class Flaky(SignalGenerator):
    def __init__(self):
        self.s, self.fail = GeneratorSettings(400.0, 1.0, 0.0, True), False

    def identify(self):
        return "FLAKY"

    def apply(self, frequency_hz, amplitude_vpp, offset_v=0.0):
        self.s = GeneratorSettings(frequency_hz, amplitude_vpp, offset_v, self.s.output)
        return self.s

    def set_amplitude(self, amplitude_vpp):
        return self.apply(self.s.frequency_hz, amplitude_vpp, self.s.offset_v)

    def set_output(self, on):
        if self.fail:
            raise InstrumentTimeout("no answer")
        self.s = GeneratorSettings(self.s.frequency_hz, self.s.amplitude_vpp, self.s.offset_v, on)

    def read_settings(self):
        return self.s

    def close(self):
        self.set_output(False)


def test_watched_generator_remembers_the_output_and_unknown_after_a_failure():
    inner = Flaky()
    g = WatchedGenerator(inner)
    assert g.read_settings().output is True and g.output is True
    g.set_output(False)
    assert g.output is False and g.output_off_at and g.snapshot()["output"] is False
    inner.fail = True
    with pytest.raises(InstrumentTimeout):
        g.set_output(False)
    assert g.output is None and "InstrumentTimeout" in g.last_error


@pytest.mark.parametrize("status, cancelled, job_status", [
    ("complete", False, "done"), ("limit", False, "failed"), ("failed", False, "failed"),
    ("aborted", False, "aborted"), ("aborted", True, "cancelled"),
])
def test_job_outcome(status, cancelled, job_status):
    got, message, error = job_outcome(PlanResult(status, "why"), n_gaps=2, cancelled=cancelled)
    assert got == job_status and "2 sample-counter gap(s)" in message
    assert (error is None) == (job_status in ("done", "cancelled"))
