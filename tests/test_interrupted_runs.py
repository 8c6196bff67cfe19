"""Interrupted acquisitions: SIGTERM closes the open run as aborted; after kill -9,
`labjoint recover` marks it incomplete with its samples and fixes the catalog."""

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from labjoint.cli.main import main
from labjoint.storage import open_run
from labjoint.storage.catalog import Catalog
import patience


#: the plan: the simulated rig streams about 13,000 cycles per second on a quiet machine
#: (three 60,000-cycle runs ended in 14 s, so the plan could end before the signal); eight
#: runs of 240,000 cycles (the rig's 600 s record limit at 400 Hz) last minutes there
LEVELS = "1,2,3,4,5,6,7,8"
CYCLES = "240000"


def _start(out):
    return subprocess.Popen([sys.executable, "-m", "labjoint.cli.main", "simulate", "--sweep",
                             LEVELS, "--cycles", CYCLES, "--out", str(out), "--json"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=os.environ.copy())


def _wait_for_samples(out, proc, timeout=120):
    end = time.monotonic() + patience.s(timeout)
    while time.monotonic() < end:
        for p in out.glob("*.h5"):
            with open_run(p) as rf:
                if rf.status == "running" and rf.n_samples > 0:     # samples flushed
                    return p
        assert proc.poll() is None, "the plan ended before it could be interrupted"
        time.sleep(0.05)
    raise AssertionError("no run started")


def _reap(proc):
    if proc.poll() is None:
        proc.kill()
    proc.wait(patience.s(60))


def _statuses(out):
    out_ = {}
    for p in sorted(out.glob("*.h5")):
        with open_run(p) as rf:
            out_[p.stem] = (rf.status, rf.n_samples)
    return out_


@pytest.mark.slow        # end to end, 40-120 s on a busy machine (issue 31)
def test_sigterm_closes_the_open_run_and_kill_9_is_recovered(tmp_path, capsys):
    a = tmp_path / "term"
    proc = _start(a)
    try:
        _wait_for_samples(a, proc)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(patience.s(6)) == 130      # 60 s at the default scale
    finally:                           # a failed wait leaves no process behind
        _reap(proc)
    st = _statuses(a)
    assert st and all(s != "running" for s, _ in st.values())
    assert "aborted" in {s for s, _ in st.values()}
    b = tmp_path / "kill"
    proc = _start(b)
    try:
        hit = _wait_for_samples(b, proc)
    finally:
        _reap(proc)
    assert _statuses(b)[hit.stem][0] == "running"
    assert main(["recover", "--data", str(b), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["recovered"] == [str(hit)] and not res["still_running"]
    status, n = _statuses(b)[hit.stem]
    assert status == "incomplete" and n > 0
    assert Catalog(b / "catalog.sqlite").get(hit.stem).status == "incomplete"
    assert main(["recover", "--data", str(b), "--json"]) == 0          # idempotent
    assert json.loads(capsys.readouterr().out)["recovered"] == []
