"""A damaged run file in `labjoint reprocess` (issue 33 item 18): on the Dask workers and
in one process, the failure names the file, no worker prints a traceback, the other runs
are computed."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from labjoint.storage import Catalog
from test_api_helpers import write_linear_run

ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
MAIN = "import sys; from labjoint.cli.main import main; sys.exit(main())"


@pytest.fixture()
def lab(tmp_path):
    cat = Catalog(tmp_path / "catalog.sqlite")
    for name in ("good", "bad"):
        write_linear_run(tmp_path, cat, name, n=6000)
    with open(tmp_path / "bad.h5", "r+b") as fh:   # garbage in the header area (after indexing)
        fh.seek(800)
        fh.write(bytes(range(256)) * 2)
    return tmp_path


@pytest.mark.parametrize("where", [["--scheduler", "none"],
                                   pytest.param(["--workers", "1"], marks=pytest.mark.slow)])
def test_a_damaged_file_fails_by_name_and_the_rest_is_computed(lab, where):
    r = subprocess.run([sys.executable, "-c", MAIN, "reprocess", "--data-dir", str(lab),
                        "--pipeline", "analyze", "--quiet", *where], env=ENV,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("labjoint: error:")]
    assert len(errors) == 1 and str(lab / "bad.h5") in errors[0]
    assert "1 computed" in r.stdout and "1 failed" in r.stdout
