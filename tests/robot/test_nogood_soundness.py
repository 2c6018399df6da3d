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
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import trajectory
from cplus.planner import iter_histories
from cplus.robot import RefineStatus, RobotTask, TaskError, refine
from cplus.robot.offline.nogoods import Nogood, NogoodStore, position_nogood
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



def _plans(task: RobotTask, nogood: Nogood | None = None) -> tuple[Counter, dict, NogoodStore]:
    """Every plan of the tiny query, by its states (how many, and the states themselves), with
    ``nogood`` in the solver at every step, and the store that holds it."""
    session = QuerySession(task.domain.theory, task.domain.query("0"))
    store = NogoodStore(session.horizon, task.domain.theory.atoms)
    if nogood is not None:
        store.add(nogood)
    count: Counter = Counter()
    states: dict = {}
    for m in range(task.domain.query("0").hi + 1):
        if session.solve_at(m):
            for hist in iter_histories(session):
                key = tuple(tuple(sorted((gc.text, str(v)) for gc, v in s.items())) for s in hist.states)
                count[key] += 1
                states[key] = list(hist.states)
    return count, states, store


@st.composite
def boxes(draw) -> dict:
    """A box over one motion (or one state) of the payload's ends or of a robot, in the grid."""
    span = draw(st.sampled_from([0, 1]))
    bodies = draw(st.sampled_from([("pl1", "pl2"), ("r1",), ("r2",), ("pl2",)]))
    box = {}
    for off in range(span + 1):
        for body in bodies:
            for axis, top in ((0, 3), (1, 4)):
                lo = draw(st.integers(0, top))
                box[(off, body, axis)] = (lo, draw(st.integers(lo, top)))
    return box


@pytest.fixture(scope="module")
def open_task(tmp_path_factory):
    scene = tmp_path_factory.mktemp("open") / "scene.toml"
    scene.write_text(tiny_scene([]))
    task = RobotTask.load(str(DOMAIN), str(scene))
    every, states, _ = _plans(task)
    return task, every, states


def _inside(task: RobotTask, box: dict, states: list) -> bool:
    """Does some window of ``states`` have every coordinate of ``box`` inside its range?"""
    span = max(off for off, _, _ in box)
    return any(all(lo <= states[t + off][task.body_fluents(body)[axis]] <= hi
                   for (off, body, axis), (lo, hi) in box.items())
               for t in range(len(states) - span))


@given(box=boxes())
@settings(max_examples=25, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
def test_the_solver_forbids_exactly_the_plans_inside_a_box(open_task, box):
    """A widened nogood in the solver removes exactly the plans with a window inside its box,
    read from the box itself (every plan of the tiny task, enumerated without it, is the
    reference); the store's own reading of its clauses agrees."""
    assume(any((lo, hi) != ((0, 3) if axis == 0 else (0, 4)) for (_, _, axis), (lo, hi) in box.items()))
    task, every, states = open_task
    left, _, store = _plans(task, position_nogood(task, box))
    assert left == Counter({k: n for k, n in every.items() if not _inside(task, box, states[k])})
    assert all((store.excludes(states[k]) is None) == (k in left) for k in every)
