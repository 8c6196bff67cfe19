"""Reprocess on Dask: a 2-worker LocalCluster, and a `dask scheduler` started as its own
process on localhost with one worker; a worker that dies mid-task is retried once, then
reported; an unreachable scheduler is one clear line; diagnose's candidate refits on the
cluster rank as the serial ones do. Runs of the linear joint F = k u + c du/dt (seed 002
Eq. 1 returns C = c, loop slope K = k)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time

import cloudpickle
import pytest

from labjoint.batch.cluster import DaskExecutor, DaskRunner, dask_client
from labjoint.batch.reprocess import execute, plan_reprocess
from labjoint.batch.tasks import run_task
from labjoint.cli.main import main
from labjoint.compare import diagnose_runs
from labjoint.storage import Catalog
from labjoint.storage.results import Results
from test_api_helpers import write_linear_run
from test_compare_synth import sweep
import patience

CASES = {"lin_a": (3e-6, 8e6, 300.0), "lin_b": (6e-6, 1.2e7, 800.0), "lin_c": (4e-6, 1e7, 500.0)}

# the worker-killing task below lives in this module, which workers cannot import
cloudpickle.register_pickle_by_value(sys.modules[__name__])


@pytest.fixture()
def lab(tmp_path):
    cat = Catalog(tmp_path / "catalog.sqlite")
    for name, (u, k, c) in CASES.items():
        write_linear_run(tmp_path, cat, name, amp_m=u, k=k, c=c, n=6000)
    return tmp_path, cat


@pytest.fixture(scope="module")
def client():
    with dask_client("local", n_workers=2, dashboard=None) as c:
        yield c


def _check_physics(rows):
    by = {r["run"]: r for r in rows}
    for name, (u, k, c) in CASES.items():
        assert by[name]["status"] == "computed", by[name]
        assert by[name]["summary"]["damping_ns_per_m"] == pytest.approx(c, rel=0.01)
        assert by[name]["summary"]["stiffness_n_per_m"] == pytest.approx(k, rel=0.01)


@pytest.mark.slow        # end to end, 40-120 s on a busy machine (issue 31)
def test_cli_on_a_two_worker_local_cluster(lab, capsys):
    d, _ = lab
    argv = ["reprocess", "--data-dir", str(d), "--pipeline", "analyze", "--workers", "2"]
    assert main(argv + ["--json"]) == 0
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert out["computed"] == 3 and out["failed"] == 0
    assert "Dask dashboard: http" in cap.err
    _check_physics(out["runs"])
    assert main(argv + ["--json"]) == 0                     # nothing changed: no work
    assert json.loads(capsys.readouterr().out)["skipped"] == 3


def _die_on_lin_b(task):
    """A task whose worker process dies (as on an out-of-memory kill) for run lin_b."""
    if task.key == "lin_b":
        os._exit(1)
    return run_task(task)


@pytest.mark.slow        # end to end, 40-120 s on a busy machine (issue 31)
def test_a_worker_dying_mid_task_is_retried_once_then_reported(lab, client):
    d, cat = lab
    res = Results(cat)
    plan = plan_reprocess(res, cat.query(), "analyze", {})
    rep = execute(plan, DaskRunner(client, _die_on_lin_b), res)
    by = {r["run"]: r for r in rep["runs"]}
    assert by["lin_b"]["status"] == "failed" and "died" in by["lin_b"]["error"]
    assert by["lin_a"]["status"] == by["lin_c"]["status"] == "computed"
    assert [t.key for t in plan_reprocess(res, cat.query(), "analyze", {}).tasks] == ["lin_b"]


def test_diagnose_refits_on_the_cluster_rank_as_serial(client):
    from distributed import get_task_stream

    runs = sweep(freqs=(200.0, 400.0), amps=(3e-6, 8e-6), k=1e7, c=120.0, cycles=12)
    opts = {"candidates": "viscous,coulomb,cubic_stiffness", "n_jobs": 1}
    serial = diagnose_runs(runs, "linear_stiffness", **opts)
    with get_task_stream(client) as ts:
        spread = diagnose_runs(runs, "linear_stiffness", **opts, executor=DaskExecutor(client))
    assert any("_refit" in str(t["key"]) for t in ts.data)           # ran on the workers
    assert [c["effect"] for c in spread["candidates"]] == \
        [c["effect"] for c in serial["candidates"]]
    assert [c["nrmse_after"] for c in spread["candidates"]] == \
        pytest.approx([c["nrmse_after"] for c in serial["candidates"]], rel=1e-9)
    assert serial["candidates"][0]["effect"] == "viscous"            # the hidden c


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture()
def scheduler():
    """`dask scheduler` and one `dask worker` as processes of their own on localhost."""
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    dask = os.path.join(os.path.dirname(sys.executable), "dask")
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        deadline = time.monotonic() + patience.s(30)
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise RuntimeError("dask scheduler did not start")
                time.sleep(0.2)
        procs.append(subprocess.Popen([dask, "worker", addr, "--nthreads", "1",
                                       "--no-dashboard"], stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL))
        yield addr
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=patience.s(20))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


@pytest.mark.slow        # end to end, 40-120 s on a busy machine (issue 31)
def test_cli_on_a_separately_started_scheduler(lab, scheduler, capsys):
    d, _ = lab
    code = main(["reprocess", "--data-dir", str(d), "--pipeline", "analyze", "--scheduler",
                 scheduler, "--json"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    _check_physics(json.loads(cap.out)["runs"])


def test_an_unreachable_scheduler_is_one_clear_line(lab, capsys):
    d, _ = lab
    addr = f"tcp://127.0.0.1:{_free_port()}"
    assert main(["reprocess", "--data-dir", str(d), "--pipeline", "analyze", "--scheduler",
                 addr]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot reach the Dask scheduler" in err[0] and addr in err[0]


def test_a_diagnose_group_on_workers_with_and_without_spread_refits_agrees(lab, client):
    """A Dask worker may not start processes: without spread the refits run in the task."""
    d, cat = lab
    res = Results(cat)
    opts = {"model": "linear_stiffness", "candidates": "viscous,cubic_stiffness"}
    reports = [execute(plan_reprocess(res, cat.query(), "diagnose", opts, force=True,
                                      spread=spread), DaskRunner(client), res)
               for spread in (False, True)]
    for rep in reports:
        assert rep["computed"] == 3 and rep["failed"] == 0, rep
    a, b = (r["runs"][0]["summary"] for r in reports)
    assert a["candidates"] == b["candidates"] and a["significant"] == b["significant"]
    assert a["nrmse"] == pytest.approx(b["nrmse"], rel=1e-12)


def test_runs_sent_in_chunks_are_each_recorded_and_a_vanished_one_named(lab, client):
    d, cat = lab
    res = Results(cat)
    plan = plan_reprocess(res, cat.query(), "analyze", {})
    (d / "lin_c.h5").unlink()                       # gone after the plan, before its task
    runner = DaskRunner(client, chunk=2)
    assert [len(c) for c in runner._chunks(plan.tasks)] == [2, 1]
    rep = execute(plan, runner, res)
    by = {r["run"]: r for r in rep["runs"]}
    assert by["lin_c"]["status"] == "failed" and "disappeared" in by["lin_c"]["error"]
    assert rep["computed"] == 2
    for name in ("lin_a", "lin_b"):
        u, k, c = CASES[name]
        assert by[name]["summary"]["damping_ns_per_m"] == pytest.approx(c, rel=0.01)
        assert by[name]["summary"]["stiffness_n_per_m"] == pytest.approx(k, rel=0.01)
