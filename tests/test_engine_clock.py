"""Issue 18 item 12: a run says when its sample 0 was taken (host time at the DAQ task's
start plus the sample index over the rate) and the drive frequency measured on the
reference channel, on the DAQ's clock, when the generator's clock runs 50 ppm fast."""

from datetime import datetime

import numpy as np
import pytest

from labjoint.acquisition.messages import Configure, Output, Record, WaitSteady
from test_engine import FS, FakeDAQ, make

PPM = 50e-6


class DriftingDAQ(FakeDAQ):
    """The fake plant, but the generator's sine runs (1 + 50 ppm) fast on the DAQ's clock
    and the task start is stamped like NIDAQ's."""

    def start(self):
        super().start()
        self.started_at, self.started_at_uncertainty_s = 1.7e9 + self.starts, 0.002
        self._abs = 0

    def read(self, n_samples, out=None):
        s = self.gen.read_settings()
        real = type(s)(s.frequency_hz * (1 + PPM), s.amplitude_vpp, s.offset_v, s.output)
        self.gen.s, keep = real, self.gen.s
        try:
            return super().read(n_samples, out)
        finally:
            self.gen.s = keep


@pytest.fixture
def run():
    engine, gen, _, col = make(noise=1e-4)
    engine.daq = engine.sampler.daq = daq = DriftingDAQ(gen, noise=1e-4)
    plan = [Configure(400.0, 2.0), Output(True),
            WaitSteady(tol=1e-12, window=4, max_cycles=200),  # reads 200 cycles: 10 blocks
            Record("r", duration_s=2.0)]
    result = engine.run(plan, name_prefix="")
    assert result.status == "complete"
    (r,) = col.runs()
    return r, daq


def test_start_time_is_when_sample_0_of_the_run_was_taken(run):
    r, daq = run
    start = r[0][1]
    md = start.metadata
    first = md["first_sample_index"]
    assert first > 0  # the steady-state wait read samples before the run opened
    t = datetime.fromisoformat(md["start_time"]).timestamp()
    assert t == pytest.approx(daq.started_at + first / FS, abs=1e-6)
    assert datetime.fromisoformat(md["daq_started_at"]).timestamp() == pytest.approx(daq.started_at)
    assert md["start_time_uncertainty_s"] == 0.002 and "announced_time" in md


def test_drive_frequency_is_measured_on_the_daq_clock(run):
    r, _ = run
    md, stop = r[0][1].metadata, r[-1][1].metadata
    assert md["frequency_hz"] == 400.0                       # what the generator was set to
    for m in (md, stop):                                      # before the run, and over it
        assert m["frequency_measured_on"] == "force_ref"
        f, u = m["frequency_measured_hz"], m["frequency_measured_uncertainty_hz"]
        assert abs(f - 400.0 * (1 + PPM)) < max(4 * u, 1e-4) and u < 2e-3
        assert abs(f - 400.0) > 5 * u                         # the 20 mHz offset is resolved
