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
