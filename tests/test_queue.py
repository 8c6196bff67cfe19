"""The persistent job queue: validation, state machine, atomic claims across threads and
processes, operator requests (cancel, torque, estop), persistence (SQLite WAL)."""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
import textwrap
import threading

import pytest

from labjoint.daemon.queue import JOB_STATUSES, JobNotFound, JobQueue, JobStateError
from labjoint.errors import InputError
import patience

DWELL = {"plan": "dwell", "frequency_hz": 400.0, "amplitude_vpp": 2.0, "n_cycles": 10}


@pytest.fixture
def q(tmp_path):
    return JobQueue(tmp_path / "queue.sqlite")


def test_submit_stores_the_validated_plan_and_queues_it(q):
    job_id = q.submit(DWELL, submitted_by="alice")
    job = q.get(job_id)
    assert job.status == "queued" and job.plan == DWELL and job.submitted_by == "alice"
    assert job.progress == 0.0 and job.runs == [] and job.started_at is None
    assert q.get("no-such-id") is None


@pytest.mark.parametrize("plan, field", [
    ({"frequency_hz": 400.0}, "plan"),
    ({"plan": "no_such_plan"}, "plan"),
    ({"plan": "dwell", "frequency_hz": -1.0, "amplitude_vpp": 2.0}, "frequency_hz"),
    ({"plan": "dwell", "frequency_hz": 400.0}, "amplitude_vpp"),
    ({"plan": "dwell", "frequency_hz": float("nan"), "amplitude_vpp": 2.0}, "plan"),
    ({"plan": "step_sine", "frequencies_hz": [400, 400], "force_amplitude_n": 5.0}, "frequencies_hz"),
])
def test_bad_plans_are_refused_naming_the_field_and_nothing_is_stored(q, plan, field):
    with pytest.raises(InputError) as err:
        q.submit(plan)
    assert err.value.field == field
    assert q.list() == []


def test_claims_are_fifo_and_mark_the_job_running(q):
    ids = [q.submit({**DWELL, "n_cycles": k}) for k in (1, 2, 3)]
    first = q.claim_next("w1")
    assert first.id == ids[0] and first.status == "running" and first.worker == "w1"
    assert first.started_at is not None
    assert [q.claim_next("w1").id for _ in range(2)] == ids[1:]
    assert q.claim_next("w1") is None


def test_concurrent_claims_from_threads_take_each_job_exactly_once(q):
    ids = {q.submit(DWELL) for _ in range(40)}
    got: list[str] = []
    lock = threading.Lock()

    def worker(name):
        while (job := q.claim_next(name)) is not None:
            with lock:
                got.append(job.id)

    threads = [threading.Thread(target=worker, args=(f"t{i}",)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(got) == sorted(ids)


CLAIMER = textwrap.dedent("""
    import json, sys
    from labjoint.daemon.queue import JobQueue
    q = JobQueue(sys.argv[1])
    print("ready", flush=True)
    sys.stdin.readline()  # start together, so the claims really race
    got = []
    while (job := q.claim_next(sys.argv[2])) is not None:
        got.append(job.id)
    print(json.dumps(got))
""")


def test_concurrent_claims_from_processes_take_each_job_exactly_once(q):
    ids = {q.submit(DWELL) for _ in range(60)}
    procs = [subprocess.Popen([sys.executable, "-c", CLAIMER, str(q.db_path), f"p{i}"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
             for i in range(2)]
    for p in procs:
        assert p.stdout.readline().strip() == "ready"
    got = []
    for p in procs:
        out, _ = p.communicate("go\n", timeout=patience.s(60))
        assert p.returncode == 0
        got += json.loads(out)
    assert sorted(got) == sorted(ids)
    assert all(q.get(i).status == "running" for i in ids)


def test_cancel_follows_the_state_machine(q):
    queued = q.submit(DWELL)
    job = q.cancel(queued)
    assert job.status == "cancelled" and job.finished_at is not None
    with pytest.raises(JobStateError):
        q.cancel(queued)
    running = q.submit(DWELL)
    q.claim_next("w")
    job = q.cancel(running)
    assert job.status == "running" and job.cancel_requested  # the daemon aborts it
    q.update(running, status="aborted")
    with pytest.raises(JobStateError):
        q.cancel(running)
    with pytest.raises(JobNotFound) as err:
        q.cancel("nope")
    assert err.value.field == "job_id"


def test_torque_confirmation_only_while_waiting_and_answer_taken_once(q):
    job_id = q.submit({"plan": "torque_series", "torques_nm": [3.0, 8.0]})
    with pytest.raises(JobStateError):
        q.continue_torque(job_id, 8.0)  # still queued
    q.claim_next("w")
    q.update(job_id, status="waiting_torque", waiting_for={"kind": "torque", "torque_nm": 8.0})
    with pytest.raises(InputError) as err:
        q.continue_torque(job_id, -2.0)
    assert err.value.field == "torque_nm"
    job = q.continue_torque(job_id, 7.9)
    assert job.status == "running" and job.waiting_for is None
    with pytest.raises(JobStateError):
        q.continue_torque(job_id, 7.9)  # not waiting any more
    assert q.take_torque_answer(job_id) == 7.9
    assert q.take_torque_answer(job_id) is None


def test_list_filters_pages_and_orders_newest_first(q):
    ids = [q.submit(DWELL) for _ in range(5)]
    q.cancel(ids[1])
    assert [j.id for j in q.list()] == ids[::-1]
    assert [j.id for j in q.list(status="cancelled")] == [ids[1]]
    assert [j.id for j in q.list(limit=2, offset=1)] == ids[::-1][1:3]
    assert q.counts()["queued"] == 4 and set(q.counts()) == set(JOB_STATUSES)
    with pytest.raises(InputError) as err:
        q.list(status="finished")
    assert err.value.field == "status"
    with pytest.raises(InputError):
        q.list(limit=-1)


def test_update_checks_fields_and_round_trips_json(q):
    job_id = q.submit(DWELL)
    job = q.update(job_id, progress=0.5, runs=["a", "b"], gaps=[{"run": "a", "expected": 5, "got": 9}],
                   message="half")
    assert (job.progress, job.runs, job.gaps[0]["got"], job.message) == (0.5, ["a", "b"], 9, "half")
    for bad in ({"progress": 1.5}, {"status": "finished"}, {"plan": {}}, {}):
        with pytest.raises(InputError):
            q.update(job_id, **bad)
    with pytest.raises(JobNotFound):
        q.update("nope", progress=0.1)


def test_estop_is_persistent_until_cleared_and_seen_by_other_instances(q, tmp_path):
    other = JobQueue(q.db_path)
    assert q.estop_requested() is None
    q.request_estop("smoke from amplifier")
    assert other.estop_requested() == "smoke from amplifier"
    other.clear_estop()
    assert q.estop_requested() is None


def test_orphans_of_a_dead_daemon_fail(q):
    a, b, c = (q.submit(DWELL) for _ in range(3))
    q.claim_next("dead")
    q.claim_next("dead")
    q.update(b, status="waiting_torque", waiting_for={"torque_nm": 8.0})
    assert sorted(q.fail_orphans("daemon restarted")) == sorted([a, b])
    for i in (a, b):
        job = q.get(i)
        assert job.status == "failed" and job.error == "daemon restarted" and job.waiting_for is None
    assert q.get(c).status == "queued"


def test_queue_is_wal_and_persists_across_instances(q):
    job_id = q.submit(DWELL)
    q.set_daemon_status({"state": "idle", "generator": {"output": False}})
    again = JobQueue(q.db_path)
    assert again.get(job_id).plan == DWELL
    st = again.daemon_status()
    assert st["state"] == "idle" and st["generator"]["output"] is False and st["updated_at"]
    with sqlite3.connect(q.db_path) as con:
        assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_a_file_that_is_not_a_database_is_refused(tmp_path):
    bad = tmp_path / "queue.sqlite"
    bad.write_bytes(b"this is not sqlite" * 100)
    with pytest.raises(InputError) as err:
        JobQueue(bad)
    assert err.value.file == str(bad)
