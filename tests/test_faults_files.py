"""Fault injection on run files (issue 33 items 14 and 15): garbage in a file's header
area, and a reprocess killed (SIGKILL) while it writes processed results.

A damaged file is listed as unreadable, by name, and everything else starts; the flags
a killed non-SWMR writer leaves are cleared by ``labjoint recover``, which says so,
while a live writer's are left alone."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time

import h5py
import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.errors import InputError
from labjoint.storage import Catalog, open_run, recover_all
from labjoint.storage.processed import write_processed
from labjoint.storage.recover import clear_dead_writer
from test_daemon_fixtures import make_daemon
from test_storage_fixtures import FS, write_run

ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
# offset 800 of a run file written by RunWriter lands in the fractal heap of /entry's
# attributes: h5py then raises RuntimeError ("... attribute exists by name ...")
GARBAGE_AT = 800


def _runs(d, names=("good", "bad")):
    t = np.arange(2000) / FS
    volts = np.vstack([np.sin(2 * np.pi * 400 * t)] * 4) * 0.1
    return [write_run(d, n, volts) for n in names]


def _garble(p, at=GARBAGE_AT):
    with open(p, "r+b") as fh:
        fh.seek(at)
        fh.write(bytes(range(256)) * 2)


def test_the_garbled_file_raises_a_runtime_error_in_h5py_itself(tmp_path):
    _, bad = _runs(tmp_path)
    _garble(bad)
    with pytest.raises(RuntimeError), h5py.File(bad, "r") as f:
        "labjoint_format" in f["entry"].attrs          # noqa: B015 (the check open_run makes)
    with pytest.raises(InputError, match="bad.h5"):
        open_run(bad)


def test_recover_lists_a_garbled_file_by_name_and_indexes_the_rest(tmp_path, capsys):
    good, bad = _runs(tmp_path)
    _garble(bad)
    assert main(["recover", "--data", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["added_to_catalog"] == ["good"]
    assert list(out["not_indexed"]) == [str(bad)]
    assert Catalog(tmp_path / "catalog.sqlite").get("good").path == str(good)


def test_the_daemon_starts_beside_a_garbled_file(tmp_path):
    d = tmp_path / "data"
    d.mkdir()
    _, bad = _runs(d)
    _garble(bad)
    daemon = make_daemon(tmp_path)
    daemon.start()
    try:
        assert daemon.catalog is not None
    finally:
        daemon.stop()


def _flags(p) -> int:
    with open(p, "rb") as fh:
        return fh.read(12)[11]


WRITER = textwrap.dedent("""
    import sys, numpy as np
    from labjoint.documents import Block, RunStart
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.writer import RunWriter
    chans = [ChannelSpec(n, "voltage", "voltage", "V", 1.0) for n in ("a", "b")]
    w = RunWriter(sys.argv[1], flush_interval_s=0.0)
    w("start", RunStart("k9", "killed", chans, 1000.0, {}))
    for first in range(0, 5000, 250):
        idx = np.arange(first, first + 250, dtype=float)
        w("block", Block("k9", first, np.vstack([idx, -idx])))
    print("go", flush=True)
    import time; time.sleep(60)
""")


def test_a_garbled_file_of_a_dead_swmr_writer_does_not_hang_recover(tmp_path):
    """A SWMR reader retries bad metadata 100 times with a doubling sleep (hours)."""
    with subprocess.Popen([sys.executable, "-c", WRITER, str(tmp_path)], env=ENV,
                          stdout=subprocess.PIPE, text=True) as proc:
        assert proc.stdout.readline().strip() == "go"
        proc.send_signal(signal.SIGKILL)
    p = tmp_path / "killed.h5"
    assert _flags(p) & 0x04                            # left with SWMR-write flags
    _garble(p)
    unreadable: dict[str, str] = {}
    t0 = time.monotonic()
    assert recover_all(tmp_path, unreadable=unreadable) == []
    assert time.monotonic() - t0 < 20.0
    assert list(unreadable) == [str(p)]


REPROCESS = textwrap.dedent("""
    import sys, numpy as np
    from labjoint.storage.processed import write_processed
    big = np.arange(200_000, dtype=float)
    print("go", flush=True)
    while True:
        for p in sys.argv[1:]:
            write_processed(p, "loop", {"energy": big, "steady": big > 5})
""")


def _kill_mid_write(paths) -> None:
    with subprocess.Popen([sys.executable, "-c", REPROCESS, *map(str, paths)], env=ENV,
                          stdout=subprocess.PIPE, text=True) as proc:
        assert proc.stdout.readline().strip() == "go"
        time.sleep(1.0)
        proc.send_signal(signal.SIGKILL)


def test_recover_clears_the_flags_a_killed_reprocess_left_and_says_so(tmp_path, capsys):
    runs = _runs(tmp_path, ("r1", "r2", "r3"))
    cat = Catalog(tmp_path / "catalog.sqlite")
    for p in runs:
        cat.add(p)
    for _ in range(5):                           # the kill lands inside a write (r+ open)
        _kill_mid_write(runs)
        flagged = [p for p in runs if _flags(p)]
        if flagged:
            break
    assert flagged, "the kill never landed inside a write"
    with pytest.raises(InputError, match="labjoint recover"):
        write_processed(flagged[0], "loop", {"x": np.zeros(3)})
    with pytest.raises(InputError, match="labjoint recover"):     # analyze says so too
        open_run(flagged[0])
    assert main(["recover", "--data", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["cleared_flags"] == [str(p) for p in flagged]
    for p in runs:
        assert _flags(p) == 0
        with open_run(p) as rf:
            assert rf.status == "complete" and rf.n_samples == 2000
        write_processed(p, "loop", {"x": np.zeros(3)})       # writable again
    assert main(["recover", "--data", str(tmp_path)]) == 0
    assert "nothing to recover" in capsys.readouterr().out


HOLDER = textwrap.dedent("""
    import sys, time, h5py
    f = h5py.File(sys.argv[1], "r+")
    print("go", flush=True)
    time.sleep(60)
""")


def test_a_live_writers_flags_are_left_alone(tmp_path):
    (p,) = _runs(tmp_path, ("held",))
    with subprocess.Popen([sys.executable, "-c", HOLDER, str(p)], env=ENV,
                          stdout=subprocess.PIPE, text=True) as proc:
        assert proc.stdout.readline().strip() == "go"
        try:
            assert _flags(p) & 0x01
            assert clear_dead_writer(p) is False
            assert _flags(p) & 0x01
        finally:
            proc.kill()
    assert clear_dead_writer(p) is True
    shutil.copy(p, tmp_path / "copy.h5")
    assert clear_dead_writer(tmp_path / "copy.h5") is False      # nothing left to clear


def test_odd_entries_of_the_data_directory_are_listed_not_fatal(tmp_path, capsys):
    (good,) = _runs(tmp_path, ("good",))
    (tmp_path / "empty.h5").write_bytes(b"")
    (tmp_path / "dir.h5").mkdir()
    (tmp_path / "dangling.h5").symlink_to(tmp_path / "nowhere.h5")
    (tmp_path / "loop.h5").symlink_to(tmp_path / "loop.h5")
    (tmp_path / "trunc.h5").write_bytes(good.read_bytes()[:100])
    assert main(["recover", "--data", str(tmp_path), "--json"]) == 0
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert out["added_to_catalog"] == ["good"] and cap.err == ""
    assert sorted(out["not_indexed"]) == sorted(
        str(tmp_path / f"{n}.h5") for n in ("empty", "dir", "dangling", "loop", "trunc"))
    d = tmp_path / "data"
    d.mkdir()
    for n in ("dir.h5", "loop.h5"):
        (d / n).symlink_to(d / n) if n == "loop.h5" else (d / n).mkdir()
    daemon = make_daemon(tmp_path)
    daemon.start()
    daemon.stop()
