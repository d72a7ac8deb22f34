"""ruff and mypy (strict) are clean: run inside the suite, so they share its two processes.

``make lint`` runs the same two tools on their own.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("tool", [["ruff", "check", "scara_robust", "tests", "benchmarks", "docs"], ["mypy"]],
                         ids=["ruff", "mypy"])
def test_the_code_is_clean(tool):
    done = subprocess.run([sys.executable, "-m", *tool], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
