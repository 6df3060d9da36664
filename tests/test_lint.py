"""The code passes the project's ruff configuration (pyproject.toml: line length 120; pyflakes, pycodestyle,
bugbear, import order, pyupgrade), so CI, which runs this suite, runs the linter too."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_finds_nothing():
    pytest.importorskip("ruff")  # in the test extra
    r = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "."], cwd=ROOT, capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stdout + r.stderr
