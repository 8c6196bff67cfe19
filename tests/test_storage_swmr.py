"""Live reading by other processes (SWMR) and recovery after the writer is killed (-9)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest

from labjoint.documents import Block, RunStart, RunStop
from labjoint.errors import InputError
from labjoint.storage import Catalog, open_run, recover, recover_all
from labjoint.storage.recover import clear_status_flags, lookup3
from labjoint.storage.writer import RunWriter
from test_storage_fixtures import FS, rig_channels, walk_nexus
import patience

READER = textwrap.dedent("""
    import json, sys
    from labjoint.storage import open_run
    with open_run(sys.argv[1]) as rf:
        for line in sys.stdin:
            rf.refresh()
            v = rf.volts("disp_1")
            print(json.dumps([rf.status, rf.n_samples, float(v.sum())]), flush=True)
""")

WRITER = textwrap.dedent("""
    import sys, numpy as np
    from labjoint.documents import Block, RunStart
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.writer import RunWriter
    chans = [ChannelSpec(n, "voltage", "voltage", "V", 1.0) for n in ("a", "b")]
    w = RunWriter(sys.argv[1], flush_interval_s=0.0)
    w("start", RunStart("k9", "killed", chans, 1000.0, {"torque_nm": 5.0}))
    first = 0
    while True:
        idx = np.arange(first, first + 250, dtype=float)
        w("block", Block("k9", first, np.vstack([idx, -idx])))
        first += 250
        print(first, flush=True)   # every block is flushed (interval 0)
""")


def _ask(proc: subprocess.Popen) -> list:
    proc.stdin.write("\n")
    proc.stdin.flush()
    return json.loads(proc.stdout.readline())


def test_second_process_reads_flushed_samples_while_run_is_written(tmp_path):
    now = [0.0]
    w = RunWriter(tmp_path, flush_interval_s=1.0, clock=lambda: now[0])
    w("start", RunStart("live", "live", rig_channels(), FS, {}))
    with subprocess.Popen([sys.executable, "-c", READER, str(tmp_path / "live.h5")],
                          stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True) as reader:
        assert _ask(reader) == ["running", 0, 0.0]
        expected = 0.0
        for k in range(1, 4):
            block = np.full((4, 1000), float(k))
            w("block", Block("live", 1000 * (k - 1), block))
            expected += 1000.0 * k
            now[0] += 1.0  # the next document sees the flush interval passed
            w.flush_if_due()
            assert _ask(reader) == ["running", 1000 * k, expected]
        w("stop", RunStop("live", "complete"))
        assert _ask(reader) == ["complete", 3000, expected]
        reader.stdin.close()
        reader.wait(timeout=patience.s(20))
    assert reader.returncode == 0


def _kill_writer(data_dir, min_samples: int) -> int:
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(data_dir)],
                            stdout=subprocess.PIPE, text=True)
    flushed = 0
    try:
        while flushed < min_samples:
            line = proc.stdout.readline()
            assert line, "writer exited early"
            flushed = int(line)
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=patience.s(20))
        proc.stdout.close()
    assert proc.returncode == -signal.SIGKILL
    return flushed


def test_kill_9_leaves_a_readable_file_that_recover_marks_incomplete(tmp_path):
    flushed = _kill_writer(tmp_path, 5000)
    path = tmp_path / "killed.h5"
    with pytest.raises(OSError, match="already open for write"):
        h5py.File(path, "r+")  # HDF5 still sees the crashed writer's flags
    with open_run(path) as rf:  # ...but the file opens for reading
        assert rf.status == "running" and rf.n_samples >= flushed
    cat = Catalog(tmp_path / "catalog.db")
    assert recover_all(tmp_path, catalog=cat) == [path]
    with open_run(path) as rf:
        n = rf.n_samples
        assert rf.status == "incomplete" and n >= flushed
        assert np.array_equal(rf.volts("a"), np.arange(n, dtype=float))
        assert np.array_equal(rf.volts("b"), -np.arange(n, dtype=float))
        assert np.allclose(rf.time(), np.arange(n) / 1000.0)
        assert "recovered" in rf.metadata["reason"]
    assert cat.get("killed").status == "incomplete" and cat.get("killed").n_samples == n
    with h5py.File(path, "r+"):
        pass  # writable again
    assert walk_nexus(path) == []
    assert recover(path) is False  # only "running" files are touched


def test_recover_refuses_a_file_this_process_is_writing(tmp_path):
    w = RunWriter(tmp_path)
    w("start", RunStart("busy", "busy", rig_channels(), FS, {}))
    with pytest.raises(InputError, match="writing"):
        recover(tmp_path / "busy.h5")
    assert recover_all(tmp_path) == []
    w("stop", RunStop("busy", "complete"))
    assert recover(tmp_path / "busy.h5") is False


def test_recover_all_removes_temporaries_of_dead_writers(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    stale = tmp_path / f".x.h5.tmp-{int(dead.stdout)}-abcd"
    stale.write_bytes(b"partial")
    mine = tmp_path / f".y.h5.tmp-{os.getpid()}-abcd"
    mine.write_bytes(b"in progress")
    recover_all(tmp_path)
    assert not stale.exists() and mine.exists()


def test_lookup3_matches_the_checksum_hdf5_wrote(tmp_path):
    with h5py.File(tmp_path / "x.h5", "w", libver="latest") as f:
        f["x"] = 1
    raw = (tmp_path / "x.h5").read_bytes()[:48]
    assert raw[8] in (2, 3)
    assert lookup3(raw[:44]) == int.from_bytes(raw[44:48], "little")
    assert clear_status_flags(tmp_path / "x.h5") is False  # closed cleanly: nothing to clear


def test_clear_status_flags_refuses_a_superblock_it_cannot_verify(tmp_path):
    p = tmp_path / "x.h5"
    with h5py.File(p, "w", libver="latest") as f:
        f["x"] = 1
    raw = bytearray(p.read_bytes())
    raw[11] = 5
    raw[44] ^= 0xFF  # checksum no longer matches
    p.write_bytes(bytes(raw))
    with pytest.raises(InputError, match="checksum"):
        clear_status_flags(p)
    assert p.read_bytes() == bytes(raw)
