"""The layering contracts in pyproject.toml hold (import-linter)."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_import_contracts_hold():
    exe = Path(sys.executable).with_name("lint-imports")
    proc = subprocess.run([str(exe), "--config", str(ROOT / "pyproject.toml")],
                          cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "broken" not in proc.stdout.lower() or "0 broken" in proc.stdout.lower()


def test_every_layer_imports_on_its_own():
    for mod in ["labjoint.hardware", "labjoint.acquisition", "labjoint.storage"]:
        proc = subprocess.run([sys.executable, "-c", f"import {mod}"], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr


def test_the_architecture_map_names_only_paths_that_exist():
    import re

    text = (ROOT / "docs" / "architecture.md").read_text()
    paths = set(re.findall(r"`((?:labjoint|tests|benchmarks)/[\w/.]+)`", text))
    paths |= set(re.findall(r"\b(labjoint/[\w/]+\.py)\b", text))
    assert len(paths) >= 30
    missing = sorted(p for p in paths if not (ROOT / p).exists())
    assert not missing, f"docs/architecture.md names paths that do not exist: {missing}"


def test_the_architecture_map_lists_every_layer_of_the_contract():
    import tomllib

    text = (ROOT / "docs" / "architecture.md").read_text()
    layers = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"][
        "contracts"][0]["layers"]
    names = [m.strip().split(".")[-1] for layer in layers for m in layer.split("|")]
    assert [n for n in names if n not in text] == []
