"""A catalog outage (issue 33 item 17): the PostgreSQL server stops while `simulate`
writes runs, or under the daemon. Expected: warnings (no tracebacks), a non-zero exit or
a job that is not "done", complete run files, and the catalog in line with them once the
server is back (`labjoint recover`, or the daemon by itself)."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

import pg_server
from labjoint.cli.main import main
from labjoint.config import CONFIG_DIR, load_config
from labjoint.storage import Catalog, open_run
from test_daemon_fixtures import BLOCK, FS, SHORT, make_daemon

ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}


class Outage:
    """A PostgreSQL server of its own, stopped and started again by the test."""

    def __init__(self) -> None:
        self.srv = pg_server.start()
        self.url = self.srv.new_database()
        self.ctl = [*self.srv.runner, pg_server.find_binary("pg_ctl"), "-D",
                    str(self.srv.root / "data")]

    def down(self) -> None:
        """Stop the server (fast: with fsync and synchronous_commit off, as the test server
        runs, an immediate stop would lose commits the test relies on)."""
        subprocess.run([*self.ctl, "-m", "fast", "-w", "stop"], check=True,
                       capture_output=True, timeout=60)

    def up(self) -> None:
        opts = (f"-p {self.srv.port} -k {self.srv.root} -c listen_addresses=127.0.0.1 "
                "-c fsync=off")
        subprocess.run([*self.ctl, "-l", str(self.srv.root / "server.log"), "-o", opts, "-w",
                        "-t", "60", "start"], check=True, capture_output=True, timeout=90)


@pytest.fixture
def outage():
    o = Outage()
    yield o
    o.srv.stop()


def _config_file(tmp_path, url):
    text = (CONFIG_DIR / "rig-sim.toml").read_text()
    text = text.replace('\ndata_dir = "data"\n', f'\ndata_dir = "data"\ncatalog_url = "{url}"\n')
    p = tmp_path / "rig.toml"
    p.write_text(text)
    return p


@pytest.mark.slow
def test_simulate_through_an_outage_warns_exits_nonzero_and_recover_resyncs(tmp_path, outage):
    cfg, data = _config_file(tmp_path, outage.url), tmp_path / "data"
    cmd = [sys.executable, "-c", "import sys; from labjoint.cli.main import main; sys.exit(main())",
           "simulate", "--sweep", "1,2,3,4,5", "--cycles", "3",
           "--sample-rate", "10000", "--config", str(cfg), "--out", str(data), "--quiet"]
    with subprocess.Popen(cmd, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True) as proc:
        end = time.monotonic() + 120
        while not list(data.glob("*.h5")) and time.monotonic() < end and proc.poll() is None:
            time.sleep(0.02)
        outage.down()                            # the server dies during the first run
        out, err = proc.communicate(timeout=300)
    files = sorted(data.glob("*.h5"))
    assert len(files) == 5
    assert proc.returncode != 0, out
    assert "Traceback" not in err and "warning: the catalog" in err
    assert len(err.strip().splitlines()) <= len(files) + 1     # one line per run, at most
    for p in files:
        with open_run(p) as rf:
            assert rf.status == "complete" and rf.n_samples > 0
    outage.up()
    assert main(["recover", "--config", str(cfg), "--data", str(data)]) == 0
    rows = {r.name: r for r in Catalog(outage.url).query()}
    assert sorted(rows) == [p.stem for p in files]
    assert {r.status for r in rows.values()} == {"complete"}
    assert min(r.n_samples for r in rows.values()) > 0


def test_the_daemon_fails_the_job_and_indexes_the_runs_when_the_catalog_is_back(tmp_path,
                                                                                outage):
    cfg = load_config(overrides={"daq": {"sample_rate_hz": FS, "block_samples": BLOCK},
                                 "rig": {"catalog_url": outage.url}})
    with make_daemon(tmp_path, cfg) as daemon:
        daemon.start()
        daemon.uncatalogued.retry_s = 0.0
        outage.down()
        daemon.queue.submit({"plan": "amplitude_sweep", "amplitudes_vpp": [1.0, 2.0], **SHORT})
        job = daemon.run_one()
        assert job.status == "failed" and "catalog could not index 2 run(s)" in job.error
        for name in job.runs:
            with open_run(daemon.data_dir / f"{name}.h5") as rf:
                assert rf.status == "complete" and rf.n_samples > 0
        assert daemon.run_one() is None           # still down: nothing lost, nothing raised
        assert len(daemon.uncatalogued.files) == 2
        outage.up()
        assert daemon.run_one() is None
        assert daemon.uncatalogued.files == {}
    rows = {r.name: r for r in Catalog(outage.url).query()}
    assert sorted(rows) == sorted(job.runs)
    assert {r.status for r in rows.values()} == {"complete"}
