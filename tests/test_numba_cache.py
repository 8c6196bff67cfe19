"""Compiled kernels are cached per state of the sources (labjoint/__init__.py)."""

import os
import subprocess
import sys


def _cache_dir(env):
    out = subprocess.run([sys.executable, "-c", "import labjoint, os; print(os.environ['NUMBA_CACHE_DIR'])"],
                         env=env, capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_the_kernel_cache_lives_in_the_users_cache_keyed_by_the_sources(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    first = _cache_dir(env)
    assert first.startswith(str(tmp_path / "labjoint-numba")) and os.path.isdir(first)
    assert _cache_dir(env) == first                       # same sources, same kernels
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "mine")
    assert _cache_dir(env) == str(tmp_path / "mine")     # an explicit choice is kept
