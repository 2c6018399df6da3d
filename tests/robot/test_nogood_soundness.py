"""Learned nogoods never exclude a collision-free plan: exhaustive search on a small grid.

For random obstacles on the 4 x 4 grid of ``tiny.cp`` (whose domain leaves all geometry to the
continuous check), every plan of every length up to the query's bound is enumerated with the
plain planner and checked with the continuous checker; none that is collision-free may be
excluded by what the refinement taught the solver (learned nogoods and the pre-check), and
the refinement must answer what the exhaustive search says: the shortest collision-free
plan's length, or that there is none.
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import trajectory
from cplus.planner import iter_histories
from cplus.robot import RefineStatus, RobotTask, TaskError, refine
from cplus.sat.horizon import QuerySession

sys.path.insert(0, str(Path(__file__).parent))
from tiny_scene import DOMAIN, tiny_scene  # noqa: E402


@st.composite
def squares(draw) -> tuple[float, float, float, float]:
    cx = draw(st.floats(0.2, 2.8).map(lambda v: round(v, 2)))
    cy = draw(st.floats(0.2, 2.8).map(lambda v: round(v, 2)))
    h = draw(st.floats(0.05, 0.35).map(lambda v: round(v, 2)))
    return (cx - h, cy - h, cx + h, cy + h)


def exhaustive(task: RobotTask, hi: int):
    """Every history of the query at maxstep 0..hi, with its collision-free verdict."""
    session = QuerySession(task.domain.theory, task.domain.query("0"))
    for m in range(hi + 1):
        if session.solve_at(m):
            for hist in iter_histories(session):
                yield hist, not trajectory.all_violations(task.scene, task.states(hist))


@pytest.mark.parametrize("eager", [None, True, False])
@given(obstacles=st.lists(squares(), min_size=1, max_size=3))
@settings(max_examples=8, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
def test_learned_nogoods_never_exclude_a_collision_free_plan(tmp_path, eager, obstacles):
    scene = tmp_path / "scene.toml"
    scene.write_text(tiny_scene(obstacles))
    try:
        task = RobotTask.load(str(DOMAIN), str(scene))
        result = refine(task, "0", eager=eager)
    except TaskError as exc:   # an obstacle on the start or the goal: refused before planning
        assume("obstacle" not in str(exc))
        raise
    shortest = None
    for hist, safe in exhaustive(task, task.domain.query("0").hi):
        why = result.store.excludes(list(hist.states))
        assert not (safe and why), f"a collision-free plan of length {hist.maxstep} is excluded by {why}"
        if safe and shortest is None:
            shortest = hist.maxstep
    if shortest is None:
        assert result.status in (RefineStatus.NO_SAFE_PLAN, RefineStatus.NO_PLAN), result.reason
    else:
        assert result.status is RefineStatus.FOUND and result.history.maxstep == shortest
        assert trajectory.all_violations(task.scene, task.states(result.history)) == ()


def test_the_tiny_task_learns_from_both_bodies(tmp_path):
    """An obstacle on the way of the payload's lower end: the tiny task needs a detour of two
    more steps, and the loop learns from the payload's sweep and from r1's own path (nothing
    is eager here); the solver's plans agree with the store's own reading of its clauses."""
    scene = tmp_path / "scene.toml"
    scene.write_text(tiny_scene([(1.86, -0.04, 2.34, 0.44)]))
    task = RobotTask.load(str(DOMAIN), str(scene))
    result = refine(task, "0", eager=False)
    assert result.status is RefineStatus.FOUND and result.history.maxstep == 5
    kinds = {v.kind.value for it in result.iterations for v in it.violations}
    assert {"effector-collision", "payload-collision"} <= kinds
    assert result.store.excludes(list(result.history.states)) is None
    assert result.store.excludes(list(result.first_history.states)) is not None
