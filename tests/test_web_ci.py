"""The dashboard's browser tests run in CI (issue 33): .ci/run runs ``make test``, which
installs Debian's chromium first and deselects nothing, and makes a missing browser a
failure instead of a skip."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import test_web_support

ROOT = Path(__file__).resolve().parent.parent


def _target(makefile: str, name: str) -> tuple[str, str]:
    m = re.search(rf"^{name}:(.*)\n((?:\t.*\n?)*)", makefile, re.M)
    assert m, name
    return m.group(1), m.group(2)


def test_ci_runs_the_browser_tests_and_fails_without_a_browser(monkeypatch, tmp_path):
    ci = (ROOT / ".ci" / "run").read_text()
    assert re.search(r"^export LABJOINT_REQUIRE_BROWSER=1$", ci, re.M)
    # CI runs the README's `make test` (the suite without the slow group), then the slow
    # group: together every test, the browser ones included
    assert re.search(r"^for target in test test-slow; do$", ci, re.M)
    assert re.search(r'^\s+make "\$target"$', ci, re.M)
    markers = []
    for target in ("test", "test-slow"):
        deps, recipe = _target((ROOT / "Makefile").read_text(), target)
        assert "browser" in deps.split()
        assert "pytest" in recipe and "browser" not in recipe
        markers.append(re.search(r'pytest.* -m "?([^"\n]*)"?', recipe).group(1).strip())
    assert markers == ["not slow", "slow"]
    ini = (ROOT / "pyproject.toml").read_text()
    addopts = re.search(r"^addopts = (.*)$", ini, re.M).group(1)
    assert " -m" not in addopts and "browser" not in addopts
    # with the variable set, a missing chromium fails the test instead of skipping it
    monkeypatch.setattr(test_web_support, "CHROMIUM", tmp_path / "no-chromium")
    monkeypatch.setenv("LABJOINT_REQUIRE_BROWSER", "1")
    with pytest.raises(pytest.fail.Exception, match="must run here"):
        with test_web_support.chromium():
            pass
    monkeypatch.delenv("LABJOINT_REQUIRE_BROWSER")
    with pytest.raises(pytest.skip.Exception):
        with test_web_support.chromium():
            pass
