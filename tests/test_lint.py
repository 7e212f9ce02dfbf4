"""The code base is ruff clean (DEVELOPERS.md, engineering standards)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_clean():
    ruff = shutil.which("ruff")
    cmd = [ruff] if ruff else [sys.executable, "-m", "ruff"]
    try:
        proc = subprocess.run(
            [*cmd, "check", "geomfdi", "tests", "benchmarks", "examples"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )
    except FileNotFoundError:  # pragma: no cover - ruff is a test extra
        pytest.fail("ruff is not installed; install the test extras")
    assert proc.returncode == 0, proc.stdout + proc.stderr
