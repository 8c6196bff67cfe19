"""Fault injection on the simulated backends: DAQ overrun, a silent sample-counter jump,
generator timeout mid-plan, limits exceeded, a crash in plan code. Each shows the data
kept up to the fault, the run's and the job's status, and the generator output OFF."""

from __future__ import annotations

import numpy as np

from labjoint.acquisition import plans
from labjoint.acquisition.messages import Configure, Output, Record
from labjoint.acquisition.rig import Rig, open_rig
from labjoint.errors import InstrumentTimeout
from labjoint.hardware.interfaces import DAQ, SignalGenerator
from labjoint.storage import open_run
from test_daemon_fixtures import BLOCK, SHORT, make_daemon, samples_for, sim_config

DWELL = {"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0, "n_cycles": 400,
         "steady_max_cycles": 40, "steady_window": 5, "steady_tol": 0.05}


def _runs(daemon, job):
    out = []
    for name in job.runs:
        with open_run(daemon.data_dir / f"{name}.h5") as rf:
            out.append((rf.status, rf.n_samples, rf.gaps, rf.volts("disp_1"), rf.metadata))
    return out


def _run_job(tmp_path, plan, sub="d", **kw):
    daemon = make_daemon(tmp_path / sub, **kw)
    with daemon:
        daemon.queue.submit(plan)
        job = daemon.run_one()
        off = daemon.rig.generator.read_settings().output is False
    return daemon, job, off


def test_daq_overrun_keeps_the_samples_before_it_and_fails_the_run(tmp_path):
    def overrunning(config):
        rig = open_rig(config)
        rig.daq.inject_overrun(at_sample=6 * BLOCK)  # counted from the DAQ start (steady wait)
        return rig

    daemon, job, off = _run_job(tmp_path, DWELL, rig_factory=overrunning)
    assert job.status == "failed" and "BufferOverrun" in job.error and off
    [(status, n, gaps, volts, md)] = _runs(daemon, job)
    assert status == "failed" and gaps == [] and 0 < n < samples_for(400, 400.0)
    assert n % BLOCK == 0 and md["n_samples"] == n
    assert [m["name"] for m in md["markers"]][-1] == "fault"
    # the samples kept are exactly those of the same run without the fault (seeded sim)
    clean, clean_job, _ = _run_job(tmp_path, DWELL, sub="clean")
    [(c_status, c_n, _, c_volts, _)] = _runs(clean, clean_job)
    assert c_status == "complete" and c_n == samples_for(400, 400.0)
    np.testing.assert_array_equal(volts, c_volts[:n])


class JumpyDAQ(DAQ):
    """The simulated DAQ whose sample counter skips ``lost`` samples after ``after`` reads
    without raising (a driver that loses data silently)."""

    def __init__(self, inner: DAQ, after: int, lost: int) -> None:
        self.inner, self.after, self.lost, self.reads, self.skew = inner, after, lost, 0, 0

    def configure(self, channels, sample_rate_hz):
        return self.inner.configure(channels, sample_rate_hz)

    @property
    def channels(self):
        return self.inner.channels

    @property
    def sample_rate_hz(self):
        return self.inner.sample_rate_hz

    def start(self):
        self.inner.start()

    def read(self, n_samples, out=None):
        self.reads += 1
        if self.reads == self.after:
            self.skew += self.lost
        return self.inner.read(n_samples, out)

    @property
    def samples_read(self):
        return self.inner.samples_read + self.skew

    def stop(self):
        self.inner.stop()

    def close(self):
        self.inner.close()


def test_a_silent_sample_counter_jump_is_recorded_in_the_file_and_on_the_job(tmp_path):
    def jumpy(config):
        rig = open_rig(config)
        return Rig(config, rig.generator, JumpyDAQ(rig.daq, after=6, lost=500), rig.sim)

    daemon, job, off = _run_job(tmp_path, DWELL, rig_factory=jumpy)
    assert job.status == "done" and off
    [(status, n, gaps, _, md)] = _runs(daemon, job)
    assert len(gaps) == 1 and gaps[0][1] - gaps[0][0] == 500 and md["continuous"] is False
    assert job.gaps == [{"run": job.runs[0], "expected": gaps[0][0], "got": gaps[0][1]}]
    assert "1 sample-counter gap" in job.message
    assert daemon.queue.get(job.id).gaps == job.gaps


class TimingOutGenerator(SignalGenerator):
    """The rig's generator, but commands for more than ``max_vpp`` time out (the link
    drops mid-plan); switching the output off still works."""

    def __init__(self, inner: SignalGenerator, max_vpp: float) -> None:
        self.inner, self.max_vpp = inner, max_vpp

    def identify(self):
        return self.inner.identify()

    def apply(self, frequency_hz, amplitude_vpp, offset_v=0.0):
        if amplitude_vpp > self.max_vpp:
            raise InstrumentTimeout(f"SIM: no answer to the amplitude command ({amplitude_vpp} Vpp)")
        return self.inner.apply(frequency_hz, amplitude_vpp, offset_v)

    def set_amplitude(self, amplitude_vpp):
        if amplitude_vpp > self.max_vpp:
            raise InstrumentTimeout(f"SIM: no answer to the amplitude command ({amplitude_vpp} Vpp)")
        return self.inner.set_amplitude(amplitude_vpp)

    def set_output(self, on):
        self.inner.set_output(on)

    def read_settings(self):
        return self.inner.read_settings()

    def close(self):
        self.inner.close()


def test_generator_timeout_mid_plan_fails_the_job_keeps_earlier_runs_output_off(tmp_path):
    def flaky(config):
        rig = open_rig(config)
        return Rig(config, TimingOutGenerator(rig.generator, max_vpp=1.5), rig.daq, rig.sim)

    plan = {"plan": "amplitude_sweep", "amplitudes_vpp": [1.0, 2.0, 3.0], **SHORT}
    daemon, job, off = _run_job(tmp_path, plan, rig_factory=flaky)
    assert job.status == "failed" and "InstrumentTimeout" in job.error and off
    [(status, n, gaps, _, md)] = _runs(daemon, job)
    assert status == "complete" and n == samples_for(20, 400.0) and md["excitation_vpp"] == 1.0
    assert daemon.status()["generator"]["output"] is False


def test_limit_tripped_while_exciting_fails_the_job_with_the_limit_named(tmp_path):
    plan = {"plan": "amplitude_sweep", "amplitudes_vpp": [1.0, 4.0], **SHORT}
    daemon, job, off = _run_job(tmp_path, plan, config=sim_config(max_force_n=20.0))
    assert job.status == "failed" and job.error.startswith("limit:") and "max_force_n" in job.error
    assert off and daemon.status()["generator"]["amplitude_vpp"] <= 0.01  # ramped down first
    [(status, n, *_)] = _runs(daemon, job)  # the 1 Vpp run (peak force ~8 N) is kept whole
    assert status == "complete" and n == samples_for(20, 400.0)


def _record_at_once(frequency_hz: float = 400.0, amplitude_vpp: float = 2.0):
    """Test plan: record from the moment the sine starts (the start transient included)."""
    yield Configure(frequency_hz, amplitude_vpp)
    yield Output(True)
    yield Record("at_once", n_cycles=200)
    yield Output(False)


def test_limit_tripped_inside_a_run_closes_it_with_status_limit(tmp_path, monkeypatch):
    monkeypatch.setitem(plans.PLANS, "record_at_once", _record_at_once)
    daemon, job, off = _run_job(tmp_path, {"plan": "record_at_once"},
                                config=sim_config(max_force_n=12.0))  # start transient ~16 N
    assert job.status == "failed" and "max_force_n" in job.error and off
    [(status, n, gaps, volts, md)] = _runs(daemon, job)
    assert status == "limit" and n == BLOCK  # the block that tripped is kept
    limit = [m for m in md["markers"] if m["name"] == "limit"]
    assert limit and limit[0]["data"]["limit"] == "max_force_n" and limit[0]["data"]["value"] > 12.0


def _crashing_plan(frequency_hz: float = 400.0):
    """Test plan whose own code raises while the output is on."""
    yield Configure(frequency_hz, 2.0)
    yield Output(True)
    yield Record("before_crash", n_cycles=20)
    raise RuntimeError("bug in plan code")


def test_a_crash_in_plan_code_switches_off_fails_the_job_and_the_daemon_goes_on(tmp_path,
                                                                                 monkeypatch):
    monkeypatch.setitem(plans.PLANS, "crashing", _crashing_plan)
    with make_daemon(tmp_path) as daemon:
        crash = daemon.queue.submit({"plan": "crashing"})
        after = daemon.queue.submit(DWELL)
        job = daemon.run_one()
        assert job.id == crash and job.status == "failed"
        assert job.error == "RuntimeError: bug in plan code"
        assert daemon.rig.generator.read_settings().output is False
        [(status, n, *_)] = _runs(daemon, job)
        assert status == "complete" and n == samples_for(20, 400.0)
        assert daemon.run_one().id == after and daemon.queue.get(after).status == "done"
