"""The daemon as a real process (``python -m labjoint.daemon``) on the simulated rig paced
to real time: killed with SIGKILL mid-run (the file opens, keeps every flushed sample,
becomes 'incomplete' at the next start; the job fails), stopped with SIGTERM (run
closed 'aborted', output OFF commanded and read back before a clean exit)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from labjoint.config import load_config
from labjoint.daemon import Daemon, JobQueue
from labjoint.storage import open_run
from test_daemon_fixtures import FS, live_samples, sim_config_file, wait_for
import patience

LONG_DWELL = {"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0,
              "n_cycles": 400 * 120, "steady_max_cycles": 40, "steady_window": 5,
              "steady_tol": 0.05}


def _start(tmp_path):
    config = sim_config_file(tmp_path)
    data = tmp_path / "data"
    queue = JobQueue(data / "queue.sqlite")
    job_id = queue.submit(LONG_DWELL, submitted_by="test")
    with open(tmp_path / "daemon.log", "w") as log:  # the child keeps its own descriptor
        proc = subprocess.Popen([sys.executable, "-m", "labjoint.daemon", "--config", str(config),
                                 "--data-dir", str(data), "--poll-s", "0.05"],
                                stdout=log, stderr=subprocess.STDOUT, env={**os.environ})
    return config, data, queue, job_id, proc


def _seen_before_kill(data, proc, min_samples):
    """Wait until another process (this one) reads ``min_samples`` flushed samples live;
    returns them (disp_1 volts)."""
    def enough():
        assert proc.poll() is None, "daemon exited early"
        return live_samples(data) >= min_samples
    wait_for(enough, timeout=60, what="flushed samples in the live run file")
    [path] = sorted(data.glob("*.h5"))
    with open_run(path) as rf:
        assert rf.status == "running"
        return path, rf.volts("disp_1")


def test_sigkill_mid_run_leaves_a_readable_file_recovered_at_next_start(tmp_path):
    config, data, queue, job_id, proc = _start(tmp_path)
    try:
        path, seen = _seen_before_kill(data, proc, min_samples=int(FS))  # >= 2 flushes
        proc.send_signal(signal.SIGKILL)
        assert proc.wait(timeout=patience.s(20)) == -signal.SIGKILL
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert queue.get(job_id).status == "running"  # nobody told the queue
    with open_run(path) as rf:  # the file opens before any recovery
        assert rf.status == "running" and rf.n_samples >= len(seen)
    with Daemon(load_config(config), data, poll_s=0.05):  # the next start recovers
        pass
    with open_run(path) as rf:
        assert rf.status == "incomplete" and rf.n_samples >= len(seen)
        np.testing.assert_array_equal(rf.volts("disp_1")[: len(seen)], seen)
        assert rf.gaps == [] and rf.metadata["continuous"]
    job = queue.get(job_id)
    assert job.status == "failed" and job.error == "daemon restarted"


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_sigterm_or_sigint_stops_the_run_switches_off_and_exits_cleanly(tmp_path, sig):
    config, data, queue, job_id, proc = _start(tmp_path)
    try:
        path, seen = _seen_before_kill(data, proc, min_samples=1)
        proc.send_signal(sig)
        assert proc.wait(timeout=patience.s(30)) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    name = signal.Signals(sig).name
    job = queue.get(job_id)
    assert job.status == "aborted" and name in job.error
    assert job.message.endswith("generator output OFF")
    with open_run(path) as rf:
        assert rf.status == "aborted" and rf.n_samples >= len(seen)
    status = queue.daemon_status()
    assert status["state"] == "stopped" and status["exit_reason"] == f"signal {name}"
    assert status["output_off_confirmed"] is True and status["generator"]["output"] is False
    log = (tmp_path / "daemon.log").read_text()
    assert "generator output OFF (daemon stopping)" in log
