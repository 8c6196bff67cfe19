"""Step-sine faults (issue 33 items 5 and 6): run times that sort, a force target above
the rig's max_force_n refused at admission, and a step whose force never reached its
target reported on the job, not "done" silently."""

from __future__ import annotations

import json
import os
from datetime import datetime

import pytest

from labjoint.acquisition.admission import check_plan
from labjoint.errors import InputError
from labjoint.storage import open_run
from test_daemon_fixtures import SHORT, make_daemon, sim_config

STEP = {"plan": "step_sine", "frequencies_hz": [380.0, 420.0], "force_amplitude_n": 5.0,
        "directions": ["up"], "measure_cycles": 10, **SHORT}


def _ts(iso: str) -> float:
    return datetime.fromisoformat(iso).timestamp()


def test_step_sine_runs_start_before_they_end_and_sort_by_plan(tmp_path):
    """The simulated DAQ runs faster than real time: its sample clock ran ahead of the
    wall clock, so runs started in the future, after their own end."""
    with make_daemon(tmp_path) as daemon:
        jobs = [daemon.queue.submit(STEP) for _ in range(2)]
        done = [daemon.run_one() for _ in jobs]
    assert [j.status for j in done] == ["done", "done"], [j.message for j in done]
    rows = []
    for k, job in enumerate(done):
        for name in job.runs:
            p = daemon.data_dir / f"{name}.h5"
            with open_run(p) as rf:
                start, end = _ts(rf.metadata["start_time"]), _ts(rf.end_time)
            assert start <= end
            assert start <= os.stat(p).st_mtime + 1e-3      # not ahead of the file's writing
            rows.append((start, k, name))
    assert [k for _, k, _ in sorted(rows)] == [0, 0, 1, 1]    # the plans do not interleave


def test_a_force_target_above_max_force_is_refused_at_admission():
    cfg = sim_config()
    assert cfg.limits.max_force_n == 1000.0
    with pytest.raises(InputError) as exc:
        check_plan({**STEP, "force_amplitude_n": 1e6}, cfg)
    assert exc.value.field == "force_amplitude_n" and "max_force_n" in str(exc.value)
    check_plan({**STEP, "force_amplitude_n": 999.0}, cfg)


def test_a_step_off_its_force_target_fails_the_job_naming_the_run(tmp_path):
    # 0.05 Vpp cannot give 200 N on the simulated rig: the loop saturates, records anyway
    plan = {**STEP, "force_amplitude_n": 200.0, "max_vpp": 0.05, "initial_vpp": 0.05}
    with make_daemon(tmp_path) as daemon:
        daemon.queue.submit(plan)
        job = daemon.run_one()
    assert job.status == "failed"
    assert job.error.startswith("force did not reach its target in 2 run(s)")
    for name in job.runs:
        assert name in job.error
        with open_run(daemon.data_dir / f"{name}.h5") as rf:
            assert rf.metadata["force_converged"] is False


@pytest.mark.slow
def test_simulate_says_when_a_step_missed_its_force_and_exits_1(tmp_path, capsys):
    from labjoint.cli.main import main

    plan = tmp_path / "steps.json"
    plan.write_text(json.dumps({**STEP, "force_amplitude_n": 200.0, "max_vpp": 0.05,
                                "initial_vpp": 0.05, "frequencies_hz": [400.0]}))
    assert main(["simulate", "--plan", str(plan), "--sample-rate", "10000",
                 "--out", str(tmp_path / "d"), "--json", "--quiet"]) == 1
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert out["status"] == "complete" and len(out["force_not_converged"]) == 1
    assert "did not reach its target in 1 run(s)" in cap.err
