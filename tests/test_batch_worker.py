"""How a reprocess worker runs a record: in its own thread only, with an allocator that
reuses record-sized blocks; the results are those of the pipelined analysis."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading

import numpy as np
import pytest

import labjoint.identify.analyze as analyze_mod
from labjoint.identify.analyze import FILE_BLOCK_SAMPLES, analyze_file
from labjoint.storage import Catalog
from test_api_helpers import write_linear_run

K, C = 1.1e7, 650.0


@pytest.fixture(scope="module")
def long_run(tmp_path_factory):
    """A linear joint record spanning three file blocks (the pipelining has work to do)."""
    d = tmp_path_factory.mktemp("worker")
    n = 2 * FILE_BLOCK_SAMPLES + 60_000
    return write_linear_run(d, Catalog(d / "catalog.sqlite"), "lin", fs=50_000.0, f=120.0,
                            amp_m=4e-6, k=K, c=C, n=n)


def test_one_thread_gives_the_pipelined_results_bit_for_bit(long_run, monkeypatch):
    seen = []
    real = analyze_mod.detect_streamed

    def spy(*a, **kw):
        seen.append(threading.current_thread())
        return real(*a, **kw)

    monkeypatch.setattr(analyze_mod, "detect_streamed", spy)
    piped = analyze_file(long_run)
    inline = analyze_file(long_run, threads=False)
    assert seen[0] is not threading.main_thread()        # pipelined: a helper thread
    assert seen[1] is threading.main_thread()            # one thread: the caller's
    for key in ("energy_loss", "damping", "stiffness_lsq", "displacement_amplitude"):
        np.testing.assert_array_equal(getattr(inline, key), getattr(piped, key))
    # the linear joint's loop: C = c and K = k (seed 002 Eq. 1)
    s = inline.summary
    assert s["damping_ns_per_m"] == pytest.approx(C, rel=0.02)
    assert s["stiffness_n_per_m"] == pytest.approx(K, rel=0.02)


def test_a_refused_record_is_refused_the_same_in_one_thread(tmp_path):
    from labjoint.errors import InputError
    path = write_linear_run(tmp_path, Catalog(tmp_path / "c.sqlite"), "short", n=200)
    msgs = []
    for threads in (True, False):
        with pytest.raises(InputError) as exc:
            analyze_file(path, threads=threads)
        msgs.append(str(exc.value))
    assert msgs[0] == msgs[1]


FAULTS = textwrap.dedent("""
    import resource, sys
    import numpy as np
    from labjoint.batch.cluster import tune_allocator

    def faults(n=60):
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        for _ in range(n):
            a = np.ones(1 << 19)          # a 4 MB block, written to
            del a
        return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

    faults(5)
    untuned = faults()
    assert tune_allocator()
    faults(5)
    print(untuned, faults())
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_a_worker_reuses_freed_blocks_under_a_dask_nanny_environment():
    env = {**os.environ, "MALLOC_TRIM_THRESHOLD_": "65536"}   # what a Dask nanny sets
    out = subprocess.run([sys.executable, "-c", FAULTS], capture_output=True, text=True,
                         env=env, check=True).stdout.split()
    untuned, tuned = int(out[0]), int(out[1])
    assert untuned >= 60                   # each block mapped afresh and faulted in
    assert tuned * 10 < untuned            # reused: its pages stay mapped
