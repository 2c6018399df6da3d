"""The suite's own time limits end a test that is too slow, Hypothesis tests included.

pytest-timeout's default method raises inside the test; Hypothesis takes that exception for a
counterexample and goes on replaying and shrinking the slow example with no limit left, so a
run of the whole suite stayed half an hour in one test.  ``tests/conftest.py`` gives Hypothesis
tests the ``thread`` method instead: this runs a copy of it on a test that sleeps past its
limit, under xdist as CI runs the suite, and asks that the test fail, the next one run, and
the slow example never run again after its limit (with the default method it ran 8 times)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from walltime import wall

TESTS = Path(__file__).resolve().parent

SLOW = r'''
import time
from pathlib import Path
from hypothesis import given, settings, strategies as st

@settings(max_examples=5, database=None)
@given(st.integers())
def test_slow(x):
    with open(Path(__file__).with_name("calls"), "a") as f:
        f.write("call\n")
    time.sleep(3)

def test_after():
    pass
'''


def test_a_hypothesis_test_past_its_limit_fails_and_the_run_goes_on(tmp_path: Path) -> None:
    shutil.copy(TESTS / "conftest.py", tmp_path / "conftest.py")
    shutil.copy(TESTS / "walltime.py", tmp_path / "walltime.py")
    (tmp_path / "test_slow.py").write_text(SLOW)
    env = dict(os.environ, CPLUS_TEST_TIME_SCALE="1")    # the limit is 1 s, the sleep 3 s
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", "2",
                          "--timeout", "1", "-o", "addopts=", str(tmp_path)],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=wall(120))
    assert run.returncode == 1, run.stdout + run.stderr
    assert "1 failed, 1 passed" in run.stdout, run.stdout
    assert "test_slow" in run.stdout
    assert (tmp_path / "calls").read_text() == "call\n"
