"""Ctrl-C while bricks move: `cplus execute` and `cplus run` stop with exit code 130 and one
line, keep what they had already written, write the log gathered so far marked incomplete,
and leave no traceback. Real processes, a real SIGINT, sent once the process says the
bricks are running (no timing involved)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from walltime import ORDERLY_STOP, wall

from trajectory import StepState, build_trajectory, parse_scene, save_json
from trajectory.scene import EXAMPLE_SCENE

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]


def interruptible() -> None:
    """In the child: Ctrl-C as in a terminal (the runner may have SIGINT ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def interrupt_when(argv: list[str], marker: str) -> tuple[int, str]:
    proc = subprocess.Popen([sys.executable, "-m", "cplus", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT, preexec_fn=interruptible,
                            env=dict(os.environ, **ORDERLY_STOP))
    seen = ""
    try:
        while marker not in seen:
            line = proc.stderr.readline()      # type: ignore[union-attr]
            assert line, f"ended before {marker!r}:\n{seen}"
            seen += line
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=wall(120))
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, seen + err


def assert_incomplete(log: Path) -> None:
    """Nothing gathered is lost: the log is written, and says it stopped early and why."""
    data = json.loads(log.read_text())
    assert data["complete"] is False and "interrupt" in data["stopped"]["reason"].lower()


@pytest.fixture
def slow_trajectory(tmp_path) -> Path:
    """Two arms out and back, 4 s a step: long enough to be interrupted while running."""
    held = {"pl1": "r1", "pl2": "r2"}
    there = StepState({"r1": (4, 1), "r2": (4, 4)}, {"pl1": (4, 1), "pl2": (4, 4)}, held)
    back = StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (1, 4)}, held)
    traj = build_trajectory(parse_scene(EXAMPLE_SCENE, "example.toml"), [back, there, back], check=False,
                            points_per_step=20, step_time_s=4.0)
    return save_json(traj, tmp_path / "t.json")


def test_ctrl_c_stops_execute_with_130(slow_trajectory, tmp_path):
    log = tmp_path / "exec.json"
    # real time (emulated bricks run on simulated time by default, and would be done at once)
    code, err = interrupt_when(["execute", str(slow_trajectory), "--log", str(log), "--time-scale", "1"], "running")
    assert code == 130, err
    assert "Traceback" not in err and "interrupted" in err.rstrip().splitlines()[-1]
    assert_incomplete(log)


def test_ctrl_c_stops_run_with_130_and_keeps_the_plan(tmp_path):
    out = tmp_path / "out"
    # on simulated time: 4 s steps make the run phase last about a second of wall time
    code, err = interrupt_when(["run", str(ROOT / "domains" / "payload" / "payload.cp"), "--out", str(out),
                                "--step-time", "4", "--points-per-step", "20"], "running")
    assert code == 130, err
    assert "Traceback" not in err and "interrupted" in err.rstrip().splitlines()[-1]
    assert (out / "plan.json").is_file() and (out / "trajectory.json").is_file()
    assert_incomplete(out / "execution.json")
