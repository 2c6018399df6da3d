"""ruff and mypy stay clean: part of the test command so that no change lands without them."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("tool, args", [
    ("ruff", ["check", "--no-cache", "."]),
    ("mypy", ["--no-error-summary"]),
])
def test_static_check_is_clean(tool, args):
    proc = subprocess.run([sys.executable, "-m", tool, *args], cwd=ROOT, capture_output=True, text=True)
    report = "\n".join(line for line in (proc.stdout + proc.stderr).splitlines() if ": note:" not in line)
    assert proc.returncode == 0, f"{tool} found problems:\n{report}"


def test_every_test_has_a_time_limit(request):
    """pytest-timeout is loaded and a limit is set, so a hang fails its test instead of stalling CI."""
    assert request.config.pluginmanager.hasplugin("timeout")
    assert float(request.config.getini("timeout")) > 0
