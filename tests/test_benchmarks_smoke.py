"""Every benchmark still runs: each ``benchmarks/bench_*.py --smoke`` (the convention of
benchmarks/README.md) exits 0 and ends with its JSON line. No time is asserted: the
figures of a smoke run are not meaningful, only that the code path works end to end."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "benchmarks").glob("bench_*.py"))
#: a hang guard only (a smoke run takes seconds to a minute on a busy machine)
HANG_S = 1800


def test_every_benchmark_is_found() -> None:
    assert len(SCRIPTS) >= 17, [s.name for s in SCRIPTS]


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_benchmark_runs_in_smoke_mode(script: Path, tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
    env.pop("PYTEST_XDIST_WORKER", None)
    # one timed repeat: a smoke run's figures are not judged, only that the path runs (the
    # repeats run the same code again; bench_broadband's smoke went from ~128 s with 3)
    proc = subprocess.run([sys.executable, str(script), "--smoke", "--repeats", "1"],
                          cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=HANG_S)
    assert proc.returncode == 0, f"{script.name} --smoke failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    lines = proc.stdout.strip().splitlines()
    assert lines, f"{script.name} printed nothing"
    out = json.loads(lines[-1])
    assert out["benchmark"] and out["smoke"] is True
    assert out["figures"], f"{script.name} reported no figure"
    for fig in out["figures"]:
        assert fig["reference"] and fig["ratio"] == fig["ratio"], fig   # stated, not NaN
    assert len(out["load_before"]) == 3 and len(out["load_after"]) == 3
    assert out["numba"] and out["machine"]["nproc"] >= 1
