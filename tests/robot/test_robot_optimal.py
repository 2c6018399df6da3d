"""``--minimize`` on a robot task: the cheapest collision-free plan, refinement inside the
search.  Checked by brute force on the tiny task (a cost per move added to its domain):
every plan of the shortest collision-free length is enumerated and checked continuously, and
the refined optimum must be the least cost among the collision-free ones."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))
from tiny_scene import DOMAIN, tiny_scene  # noqa: E402

import trajectory  # noqa: E402
from cplus.cli import main  # noqa: E402
from cplus.planner import iter_histories  # noqa: E402
from cplus.robot import RefineStatus, RobotTask, TaskError, refine  # noqa: E402
from cplus.sat.horizon import QuerySession  # noqa: E402
from cplus.sat.optimize import Objective  # noqa: E402

COST = """
:- constants cost :: additiveFluent(0..12).
:- maxAdditive :: 12.
move(R,up) increments cost by 2.
move(R,down) increments cost by 2.
move(R,right) increments cost by 1.
"""


def task_files(tmp_path: Path, obstacles) -> Path:
    d = tmp_path / "task"
    d.mkdir(exist_ok=True)
    text = DOMAIN.read_text()
    cut = text.index(":- query")
    (d / "tiny.cp").write_text(text[:cut] + COST + text[cut:].replace("xpay(pl1)=0,", "xpay(pl1)=0, cost=0,", 1))
    (d / "scene.toml").write_text(tiny_scene(obstacles))
    return d / "tiny.cp"


@st.composite
def squares(draw):
    x, y = draw(st.integers(0, 3)), draw(st.integers(0, 4))
    return (x + 0.3, y + 0.3, x + 0.7, y + 0.7)


@given(obstacles=st.lists(squares(), min_size=0, max_size=2))
@settings(max_examples=6, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
def test_the_cheapest_collision_free_plan(tmp_path, obstacles):
    path = task_files(tmp_path, obstacles)
    try:
        task = RobotTask.load(str(path), str(path.with_name("scene.toml")))
        objective = Objective.parse("cost", task.domain.program.signature)
        result = refine(task, "0", minimize=objective)
    except TaskError as exc:
        assume("obstacle" not in str(exc))
        raise
    safe: dict[int, list[int]] = {}
    session = QuerySession(task.domain.theory, task.domain.query("0"))
    for m in range(task.domain.query("0").hi + 1):
        if session.solve_at(m):
            for hist in iter_histories(session):
                if not trajectory.all_violations(task.scene, task.states(hist)):
                    safe.setdefault(m, []).append(objective.value(hist))
        if safe:
            break
    if not safe:
        assert result.status is not RefineStatus.FOUND
        return
    (m, costs), = safe.items()
    assert result.status is RefineStatus.FOUND and result.history.maxstep == m
    assert result.optimum.proved and result.optimum.value == min(costs) == objective.value(result.history)
    assert not trajectory.all_violations(task.scene, task.states(result.history))


def test_the_command_prints_the_cost_and_json_has_it(tmp_path, capsys):
    path = task_files(tmp_path, [])
    code = main(["plan", str(path), "--minimize", "cost"])
    out, _ = capsys.readouterr()
    assert code == 0 and out.endswith("cost = 6 (optimal)\n\n")       # both robots three steps right
    code = main(["plan", str(path), "--minimize", "cost", "--json"])
    r = json.loads(capsys.readouterr()[0])["results"][0]
    assert r["optimum"]["value"] == 6 and r["optimum"]["proved"] and r["status"] == "found"


@pytest.mark.parametrize("argv, message", [
    (["--minimize", "cost", "--over-lengths"], "--over-lengths applies to plain domains"),
    (["--minimize", "nothing"], "'nothing' is not a ground constant"),
])
def test_robot_minimize_errors(tmp_path, capsys, argv, message):
    path = task_files(tmp_path, [])
    code = main(["plan", str(path), *argv])
    _, err = capsys.readouterr()
    assert code == 2 and message in err
