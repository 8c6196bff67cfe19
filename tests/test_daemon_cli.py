"""What the CLI calls: submitting plan files, confirming torque, cancelling, default
paths, the ``--output-off`` entry, and ``python -m labjoint.daemon`` error codes."""

from __future__ import annotations

import json

import pytest

from labjoint.daemon import JobQueue, JobStateError
from labjoint.daemon.__main__ import main
from labjoint.cli.daemon_glue import (cancel_job, confirm_torque, open_queue, output_off,
                                      submit_plan)
from labjoint.errors import InputError

TOML = """plan = "torque_series"
torques_nm = [3.0, 8.0]
amplitude_vpp = 2.0
n_cycles = 20
"""


def test_submit_a_toml_plan_file_then_confirm_torque_and_cancel(tmp_path):
    path = tmp_path / "series.toml"
    path.write_text(TOML)
    db = tmp_path / "q.sqlite"
    job = submit_plan(path, db, submitted_by="lab")
    assert job.status == "queued" and job.submitted_by == "lab"
    assert job.plan == {"plan": "torque_series", "torques_nm": [3.0, 8.0], "amplitude_vpp": 2.0,
                        "n_cycles": 20}
    with pytest.raises(JobStateError):
        confirm_torque(job.id, 3.0, db)
    q = JobQueue(db)
    q.claim_next("w")
    q.update(job.id, status="waiting_torque", waiting_for={"kind": "torque", "torque_nm": 3.0})
    assert confirm_torque(job.id, 3.1, db).status == "running"
    assert q.take_torque_answer(job.id) == 3.1
    assert cancel_job(job.id, db).cancel_requested


def test_json_plan_files_work_and_bad_ones_name_the_file_and_field(tmp_path):
    good = tmp_path / "dwell.json"
    good.write_text(json.dumps({"plan": "dwell", "frequency_hz": 400, "amplitude_vpp": 2}))
    assert submit_plan(good, tmp_path / "q.sqlite").plan["frequency_hz"] == 400
    bad = tmp_path / "bad.toml"
    bad.write_text('plan = "dwell"\nfrequency_hz = 400\namplitude_vpp = -2\n')
    with pytest.raises(InputError) as err:
        submit_plan(bad, tmp_path / "q.sqlite")
    assert err.value.file == str(bad) and err.value.field == "amplitude_vpp"
    assert JobQueue(tmp_path / "q.sqlite").counts()["queued"] == 1


def test_the_queue_defaults_to_the_data_dir(tmp_path):
    q = open_queue(data_dir=tmp_path / "data")
    assert q.db_path == tmp_path / "data" / "queue.sqlite"


def test_output_off_on_the_simulated_rig_has_nothing_to_switch(capsys):
    assert output_off()["output"] is None
    assert main(["--output-off"]) == 0
    assert json.loads(capsys.readouterr().out)["backend"] == "sim"


def test_module_entry_reports_a_bad_config_with_exit_code_2(tmp_path, capsys):
    assert main(["--config", str(tmp_path / "missing.toml")]) == 2
    assert "missing.toml" in capsys.readouterr().err


def test_submit_refuses_a_plan_beyond_the_configured_rig_before_queueing_it(tmp_path):
    path = tmp_path / "loud.toml"
    path.write_text('plan = "dwell"\nfrequency_hz = 400.0\namplitude_vpp = 500.0\n')
    db = tmp_path / "q.sqlite"
    with pytest.raises(InputError, match="500 Vpp exceeds max_vpp = 20 Vpp"):
        submit_plan(path, db)
    assert JobQueue(db).list() == []
