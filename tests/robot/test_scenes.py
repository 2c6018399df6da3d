"""The test scenes of domains/payload/scenes: an island in the way, and a wall no arm can pass.

The island's plan is re-checked twice: by the continuous checker, and by a sampling check
written here apart from it (dense samples of every motion: the payload's segment against the
obstacles with shapely, its length, each arm's reach).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import shapely

import trajectory
from cplus.cli import main
from cplus.robot import RefineStatus, RobotTask, refine

ROOT = Path(__file__).resolve().parents[2]
DOMAIN = ROOT / "domains" / "payload" / "payload.cp"
ISLAND = ROOT / "domains" / "payload" / "scenes" / "island.toml"
WALL = ROOT / "domains" / "payload" / "scenes" / "raised-wall.toml"


def sampled_problems(scene, states, samples: int = 400) -> list[str]:
    """A check independent of trajectory.checker: sample every motion densely."""
    problems = []
    obstacles = [o.polygon for o in scene.obstacles]
    low, high = scene.payload.length_sq_band
    e1, e2 = scene.end_names
    for i, (a, b) in enumerate(zip(states, states[1:])):
        for u in np.linspace(0.0, 1.0, samples):
            p1 = np.add(a.payload[e1], u * np.subtract(b.payload[e1], a.payload[e1]))
            p2 = np.add(a.payload[e2], u * np.subtract(b.payload[e2], a.payload[e2]))
            segment = shapely.LineString([p1, p2])
            if any(segment.intersects(o) for o in obstacles):
                problems.append(f"step {i} u={u:.3f}: payload hits an obstacle")
            sq = float(np.sum((p2 - p1) ** 2))
            if not low - 1e-9 <= sq <= high + 1e-9:
                problems.append(f"step {i} u={u:.3f}: squared length {sq:.3f}")
            for robot in scene.robots:
                p = np.add(a.robots[robot.name], u * np.subtract(b.robots[robot.name], a.robots[robot.name]))
                if shapely.Point(p).intersects(shapely.union_all(obstacles)):
                    problems.append(f"step {i} u={u:.3f}: {robot.name} in an obstacle")
                arm = robot.arm
                across = -(p[0] - arm.rail_origin[0]) * arm.rail_dir[1] + (p[1] - arm.rail_origin[1]) * arm.rail_dir[0]
                if abs(across) > arm.length + 1e-9:
                    problems.append(f"step {i} u={u:.3f}: {robot.name} out of reach")
    return problems


@pytest.fixture(scope="module")
def island():
    task = RobotTask.load(str(DOMAIN), str(ISLAND))
    return task, refine(task, "0")


def test_the_island_is_passed_with_default_options(island):
    task, result = island
    assert result.status is RefineStatus.FOUND and result.history.maxstep == 12
    states = task.states(result.history)
    assert trajectory.all_violations(task.scene, states) == ()
    assert sampled_problems(task.scene, states) == []
    assert states[0].payload == {"pl1": (0.0, 0.0), "pl2": (0.0, 5.0)}
    assert states[-1].payload == {"pl1": (10.0, 0.0), "pl2": (10.0, 5.0)}
    assert result.no_solution_with_maxstep == list(range(12))


def test_the_island_takes_fewer_iterations_than_the_paper_s_form(island):
    _, result = island
    assert len(result.iterations) < 60     # the paper's form: 160


def test_the_island_s_plans_are_refused_by_the_sampling_check_too(island):
    """The sampling check is not blind: the first (unsafe) plan fails it as well."""
    task, result = island
    assert sampled_problems(task.scene, task.states(result.first_history))


def test_the_raised_wall_is_proved_impossible(capsys):
    code = main(["plan", str(DOMAIN), "--scene", str(WALL), "--json"])
    out, err = capsys.readouterr()
    assert code == 4
    res = json.loads(out)["results"][0]
    assert res["status"] == "no_safe_plan" and res["histories"] == []
    assert res["no_solution_with_maxstep"] == list(range(41))
    assert res["reason"] == "no collision-free plan with maxstep 0..40 (--max-horizon)"
    assert "no collision-free plan with maxstep 0..40" in err


def test_the_raised_wall_without_geometry_has_plans():
    """What makes the wall's proof a no_safe_plan and not a no_plan: the domain alone, whose
    grid-point laws let r1 step over the wall at y >= 5, has plans (from length 13)."""
    task = RobotTask.load(str(DOMAIN), str(WALL))
    plain = task.domain.solve("0", max_horizon=40)
    assert plain.status.value == "found" and plain.maxstep == 13
    states = task.states(plain.histories[0])
    assert any(v.kind.value == "out-of-reach" for v in trajectory.all_violations(task.scene, states))
