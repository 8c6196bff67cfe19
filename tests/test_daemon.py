"""The daemon end to end on the simulated rig, through the job queue: every plan kind,
the operator's torque handshake, cancel, emergency stop, status, one daemon per queue."""

from __future__ import annotations

import numpy as np
import pytest

from labjoint.daemon import DaemonBusy, JobQueue
from labjoint.storage import Catalog, open_run
from test_daemon_fixtures import (FS, SHORT, live_samples, make_daemon, samples_for, sim_config,
                                  wait_for)

PLANS = {
    "dwell": ({"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0, **SHORT}, [400.0]),
    "amplitude_sweep": ({"plan": "amplitude_sweep", "amplitudes_vpp": [1.0, 2.0], **SHORT},
                        [400.0, 400.0]),
    "torque_series": ({"plan": "torque_series", "torques_nm": [3.0, 8.0], "amplitude_vpp": 2.0,
                       **SHORT}, [400.0, 400.0]),
    "friction_test": ({"plan": "friction_test", "amplitude_vpp": 2.0, **SHORT}, [100.0]),
    "sensor_calibration": ({"plan": "sensor_calibration", "frequencies_hz": [300.0, 500.0],
                            "amplitude_vpp": 2.0, **SHORT}, [300.0, 500.0]),
    "step_sine": ({"plan": "step_sine", "frequencies_hz": [380.0, 420.0], "force_amplitude_n": 5.0,
                   "directions": ["up"], "measure_cycles": 10, **SHORT}, [380.0, 420.0]),
    "broadband": ({"plan": "broadband", "frequencies_hz": [200.0, 450.0], "amplitude_vpp": 0.5,
                   **SHORT}, [200.0, 450.0]),
}


def _amplitude(rf, channel: str) -> float:
    x = rf.physical(channel)
    return float(np.sqrt(2.0) * np.std(x[len(x) // 2:]))


@pytest.mark.parametrize("kind", sorted(PLANS))
def test_every_plan_runs_end_to_end_through_the_queue(tmp_path, kind):
    plan, freqs = PLANS[kind]
    with make_daemon(tmp_path) as daemon:
        job_id = daemon.queue.submit(plan, submitted_by="test")
        job = daemon.run_one()
        assert job.id == job_id and job.status == "done", job.message
        assert job.progress == 1.0 and job.error is None and job.gaps == []
        assert job.message.endswith("generator output OFF")
        assert daemon.rig.generator.read_settings().output is False
        assert len(job.runs) == len(freqs)
        catalog = Catalog(daemon.catalog_db)
        files = []
        for name, f in zip(job.runs, freqs):
            with open_run(daemon.data_dir / f"{name}.h5") as rf:
                assert rf.status == "complete" and rf.gaps == [] and rf.metadata["continuous"]
                assert rf.n_samples == samples_for(plan["n_cycles"], f)
                assert rf.metadata["plan"] == kind and rf.frequency_hz == pytest.approx(f)
                assert rf.sample_rate_hz == FS
                files.append(dict(rf.metadata, disp=_amplitude(rf, "disp_1"),
                                  force=_amplitude(rf, "force_ref")))
            assert catalog.get(name).status == "complete"
        assert daemon.run_one() is None  # queue empty
    if kind == "amplitude_sweep":  # micro-slip: displacement about proportional to drive
        assert files[1]["disp"] / files[0]["disp"] == pytest.approx(2.0, rel=0.2)
    if kind == "torque_series":
        assert [m["torque_nm"] for m in files] == [3.0, 8.0]
        assert [m["normal_force_n"] for m in files] == pytest.approx([3 * 478.0, 8 * 478.0])
    if kind == "step_sine":  # closed loop on the reference force amplitude
        for m in files:
            assert m["force"] == pytest.approx(5.0, rel=0.1)


def test_operator_confirms_torque_through_the_queue_and_the_sim_applies_it(tmp_path):
    daemon = make_daemon(tmp_path, operator_torque=True)
    queue = JobQueue(daemon.queue_db)  # the operator's side: another connection
    job_id = queue.submit({"plan": "torque_series", "torques_nm": [3.0, 8.0], "amplitude_vpp": 2.0,
                           **SHORT})
    thread = daemon.start_in_thread()
    try:
        job = wait_for(lambda: (j := queue.get(job_id)).status == "waiting_torque" and j,
                       what="first torque request")
        assert job.waiting_for == {"kind": "torque", "torque_nm": 3.0}
        status = daemon.status()
        assert status["state"] == "waiting_torque" and status["job"] == job_id
        assert daemon.rig.generator.read_settings().output is False  # off while the bolt changes
        queue.continue_torque(job_id, 3.0)
        wait_for(lambda: (j := queue.get(job_id)).waiting_for == {"kind": "torque", "torque_nm": 8.0}
                 and j.status == "waiting_torque", what="second torque request")
        queue.continue_torque(job_id, 7.5)  # the operator reached 7.5 N*m, not 8
        job = wait_for(lambda: (j := queue.get(job_id)).finished and j, what="job end")
    finally:
        daemon.stop()
        thread.join(30)
    assert job.status == "done", job.message
    torques = []
    for name in job.runs:
        with open_run(daemon.data_dir / f"{name}.h5") as rf:
            torques.append((rf.metadata["torque_nm"], rf.metadata["torque_requested_nm"]))
    assert torques == [(3.0, 3.0), (7.5, 8.0)]
    assert daemon.rig is None and not thread.is_alive()


def test_cancel_aborts_the_running_job_keeps_its_data_and_switches_off(tmp_path):
    daemon = make_daemon(tmp_path, sim_config(realtime=True))
    job_id = daemon.queue.submit({"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0,
                                  "n_cycles": 400 * 60})
    thread = daemon.start_in_thread()
    try:
        wait_for(lambda: live_samples(daemon.data_dir) > 0, what="flushed samples")
        wait_for(lambda: daemon.queue.get(job_id).progress > 0, what="progress")
        status = daemon.status()
        assert status["job"] == job_id and status["samples"] > 0 and status["run"]
        assert status["generator"]["output"] is True and status["rig_backend"] == "sim"
        daemon.queue.cancel(job_id)
        job = wait_for(lambda: (j := daemon.queue.get(job_id)).finished and j, timeout=10,
                       what="cancel")
        assert daemon.rig.generator.read_settings().output is False
    finally:
        daemon.stop()
        thread.join(30)
    assert job.status == "cancelled" and job.message.endswith("generator output OFF")
    with open_run(daemon.data_dir / f"{job.runs[0]}.h5") as rf:
        assert rf.status == "aborted" and 0 < rf.n_samples < samples_for(400 * 60, 400.0)
        assert rf.gaps == []


def test_cancel_while_waiting_for_the_operator_ends_the_job_cancelled(tmp_path):
    daemon = make_daemon(tmp_path, operator_torque=True)
    job_id = daemon.queue.submit({"plan": "torque_series", "torques_nm": [3.0], **SHORT})
    thread = daemon.start_in_thread()
    try:
        wait_for(lambda: daemon.queue.get(job_id).status == "waiting_torque", what="torque request")
        daemon.queue.cancel(job_id)
        job = wait_for(lambda: (j := daemon.queue.get(job_id)).finished and j, what="cancel")
    finally:
        daemon.stop()
        thread.join(30)
    assert job.status == "cancelled" and job.runs == [] and job.waiting_for is None
    assert job.message.endswith("generator output OFF")


def test_emergency_stop_from_another_process_aborts_and_blocks_new_jobs(tmp_path):
    daemon = make_daemon(tmp_path, sim_config(realtime=True))
    operator = JobQueue(daemon.queue_db)
    long_job = operator.submit({"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0,
                                "n_cycles": 400 * 60})
    thread = daemon.start_in_thread()
    try:
        wait_for(lambda: live_samples(daemon.data_dir) > 0, what="flushed samples")
        operator.request_estop("operator pressed stop")
        job = wait_for(lambda: (j := operator.get(long_job)).finished and j, timeout=10,
                       what="estop")
        assert job.status == "aborted" and "operator pressed stop" in job.error
        assert daemon.rig.generator.read_settings().output is False
        next_job = operator.submit({"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0,
                                    **SHORT})
        wait_for(lambda: daemon.status()["estop"] == "operator pressed stop", what="status")
        thread.join(0.5)  # several poll periods
        assert operator.get(next_job).status == "held"
        operator.clear_estop()
        thread.join(0.5)
        assert operator.get(next_job).status == "held"        # clearing starts nothing
        operator.resume(next_job)
        done = wait_for(lambda: (j := operator.get(next_job)).finished and j, what="next job")
    finally:
        daemon.stop()
        thread.join(30)
    assert done.status == "done"
    with open_run(daemon.data_dir / f"{job.runs[0]}.h5") as rf:
        assert rf.status == "aborted" and rf.n_samples > 0


def test_in_process_emergency_stop_while_idle_keeps_output_off(tmp_path):
    with make_daemon(tmp_path) as daemon:
        daemon.emergency_stop("REST estop")
        assert daemon.queue.estop_requested() == "REST estop"
        assert daemon.status()["generator"]["output"] is False
        daemon.queue.submit({"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0, **SHORT})
        assert daemon.run_one() is None


def test_one_daemon_per_queue(tmp_path):
    first = make_daemon(tmp_path)
    first.start()
    second = make_daemon(tmp_path)
    with pytest.raises(DaemonBusy, match=r"pid \d+"):
        second.start()
    assert second.rig is None
    first.close()
    second.start()
    second.close()


def test_published_status_tells_other_processes_the_output_state(tmp_path):
    with make_daemon(tmp_path) as daemon:
        daemon.queue.submit({"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0, **SHORT})
        daemon.run_one()
    published = JobQueue(daemon.queue_db).daemon_status()
    assert published["state"] == "stopped" and published["output_off_confirmed"] is True
    assert published["generator"]["output"] is False and published["generator"]["output_off_at"]


def test_a_stopped_daemon_starts_again_in_a_thread(tmp_path):
    daemon = make_daemon(tmp_path)
    first = daemon.start_in_thread()
    assert daemon.start_in_thread() is first  # already running: the same thread
    daemon.stop()
    first.join(30)
    assert daemon.status()["state"] == "stopped" and daemon.rig is None
    second = daemon.start_in_thread()
    try:
        job_id = daemon.queue.submit({"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0,
                                      **SHORT})
        job = wait_for(lambda: (j := daemon.queue.get(job_id)).finished and j, what="job")
    finally:
        daemon.stop()
        second.join(30)
    assert second is not first and job.status == "done"
