"""What a violation depends on (`cause_of`), widening it (`widen`), and the eager pre-check.

Every claim these functions make is a claim about the checker's verdict on other plans, so
each is tested against the checker itself: a widened box is enumerated member by member, the
pre-check's motions are compared with a one-by-one classification, a payload turn with its
translations.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from traj_helpers import FIRST_PAYLOAD_PLAN, carried, plan

from trajectory import (
    Cause,
    StepState,
    ViolationKind,
    all_violations,
    bad_single_body_motions,
    cause_of,
    check_motion,
    failing_length_pairs,
    first_violation,
    parse_scene,
    widen,
)
from trajectory.generalize import PAYLOAD_BUDGET, payload_motions_fail
from trajectory.kinematics import choices_at, surviving_choices
from trajectory.scene import EXAMPLE_SCENE

PAYLOAD_KINDS = {ViolationKind.PAYLOAD_COLLISION, ViolationKind.PAYLOAD_LENGTH}
ROBOT_KINDS = {ViolationKind.EFFECTOR_COLLISION, ViolationKind.OUT_OF_REACH, ViolationKind.JOINT_LIMIT}


def member_fails(scene, cause: Cause, coords: dict) -> bool:
    """The checker's verdict on one member of a widened box: a plan made of the window alone,
    the robots holding the payload ends, violations of the cause's bodies only."""
    steps = cause.span + 1
    if set(cause.bodies) == set(scene.end_names):
        pts = [{b: (coords[(k, b, 0)], coords[(k, b, 1)]) for b in cause.bodies} for k in range(steps)]
        states = [carried(p["pl1"], p["pl2"]) for p in pts]
        if steps == 1:
            states = states * 2
        found = check_motion(scene, 0, states[0], states[1])
        return any(v.kind in PAYLOAD_KINDS for v in found)
    (robot,) = cause.bodies
    path = [(coords[(k, robot, 0)], coords[(k, robot, 1)]) for k in range(steps)]
    arm = scene.robot(robot).arm
    if any(not choices_at(arm, *p) for p in path):
        return True
    alive = choices_at(arm, *path[0])
    for p, q in zip(path, path[1:] or path):
        if scene.obstacles_met(*p, *q):
            return True
        alive, _ = surviving_choices(arm, alive, p, q)
        if not alive:
            return True
    return bool(scene.obstacles_met(*path[0], *path[0]))


def members(box: dict):
    keys = sorted(box)
    for values in itertools.product(*(range(lo, hi + 1) for lo, hi in (box[k] for k in keys))):
        yield dict(zip(keys, values))


# ---------------------------------------------------------------------------- cause_of


def test_a_motion_depends_on_its_two_states(payload_scene):
    states = plan(*FIRST_PAYLOAD_PLAN)
    v = first_violation(payload_scene, states)
    assert v.kind is ViolationKind.PAYLOAD_LENGTH and v.step == 3
    assert cause_of(payload_scene, states, v) == Cause(("pl1", "pl2"), 3, 4)


def test_a_state_bad_by_itself_is_the_whole_cause(payload_scene):
    # the payload lies across the low wall at step 1: any motion into or out of it fails
    states = plan(((4, 0), (4, 5)), ((4, 1), (6, 1)), ((4, 1), (4, 6)))
    causes = {cause_of(payload_scene, states, v) for v in all_violations(payload_scene, states)
              if v.kind is ViolationKind.PAYLOAD_COLLISION}
    assert Cause(("pl1", "pl2"), 1, 1) in causes


def test_a_point_no_arm_can_hold(payload_scene):
    states = plan(((3, 4), (3, 7)), ((3, 6), (3, 7)))       # r1 reaches y <= 4.5
    v = next(v for v in all_violations(payload_scene, states) if v.kind is ViolationKind.OUT_OF_REACH)
    assert cause_of(payload_scene, states, v) == Cause(("r1",), 1, 1)


RAIL_SCENE = EXAMPLE_SCENE.replace("x_max = 6", "x_max = 12").replace(
    'name = "post"\npoints = [[2, -1], [3, -1], [3, 1], [2, 1], [2, -1]]',
    'name = "far"\npoints = [[20, 20], [21, 20], [21, 21], [20, 21], [20, 20]]').replace(
    "arm_length = 3\ns_limits = [-4, 10]\ntheta_limits_deg = [5, 175]",
    "arm_length = 3\ns_limits = [-1, 7]\ntheta_limits_deg = [5, 175]")


def test_a_branch_kept_from_earlier_steps_widens_the_cause_backwards():
    """r1's carriage travels s in [-1, 7]: at y = 0 the hand-behind branch fits for x <= 4.17,
    the hand-ahead one for x >= 1.83. Starting at x = 0 the arm is committed to the first and
    cannot go on from x = 3 to x = 6, although a robot starting at x = 3 could (on the other
    branch). The cause starts where the commitment was made: at x = 1, where only the first
    branch fits."""
    scene = parse_scene(RAIL_SCENE, "rail.toml")
    path = [(0, 0), (1, 0), (3, 0), (6, 0)]
    states = [StepState({"r1": p, "r2": (p[0], 3)}, {"pl1": p, "pl2": (p[0], 3)}, {"pl1": "r1", "pl2": "r2"})
              for p in path]
    v = next(v for v in all_violations(scene, states) if v.subject == "r1")
    assert v.kind is ViolationKind.JOINT_LIMIT and v.step == 2
    cause = cause_of(scene, states, v)
    assert cause == Cause(("r1",), 1, 3)
    # the pair alone is fine, and from the cause's first step the path is not
    arm = scene.robot("r1").arm
    assert surviving_choices(arm, choices_at(arm, 3, 0), (3, 0), (6, 0))[0]
    assert member_fails(scene, cause, {(k, "r1", a): path[cause.first + k][a]
                                       for k in range(cause.span + 1) for a in (0, 1)})


# ---------------------------------------------------------------------------- widen


@st.composite
def payload_motions(draw):
    """Carried motions of the payload scene, mostly of the right length, near the obstacles."""
    x = draw(st.integers(0, 11))
    y = draw(st.integers(-1, 2))
    d0 = draw(st.sampled_from([(0, 5), (1, 5), (-1, 5), (3, 4), (-3, 4), (4, 3)]))
    move = draw(st.tuples(st.integers(-4, 4), st.integers(-2, 2)))
    turn = draw(st.sampled_from([(0, 0), (1, -1), (-1, -1), (3, -1), (0, 1), (-3, -1)]))
    a1, a2 = (x, y), (x + d0[0], y + d0[1])
    b1 = (a1[0] + move[0], a1[1] + move[1])
    b2 = (a2[0] + move[0] + turn[0], a2[1] + move[1] + turn[1])
    return a1, a2, b1, b2


def _in_grid(scene, *points) -> bool:
    g = scene.grid
    return all(g.x_min <= p[0] <= g.x_max and g.y_min <= p[1] <= g.y_max for p in points)


@given(motion=payload_motions())
@settings(max_examples=40)
def test_every_member_of_a_widened_payload_box_fails(payload_scene, motion):
    a1, a2, b1, b2 = motion
    if not _in_grid(payload_scene, *motion):
        return
    states = [carried(a1, a2), carried(b1, b2)]
    for v in all_violations(payload_scene, states):
        if v.kind not in PAYLOAD_KINDS:
            continue
        cause = cause_of(payload_scene, states, v)
        box = widen(payload_scene, states, cause)
        exact = {(k - cause.first, b, a): int(states[k].payload[b][a])
                 for k in range(cause.first, cause.last + 1) for b in cause.bodies for a in (0, 1)}
        assert all(box[key][0] <= value <= box[key][1] for key, value in exact.items())
        size = math.prod(hi - lo + 1 for lo, hi in box.values())
        assert size <= PAYLOAD_BUDGET + 1     # every member was tested while growing
        assert all(member_fails(payload_scene, cause, m) for m in members(box))


def test_a_widened_robot_box_fails_everywhere(example_scene):
    """r1 runs into the example's post; every move of the widened box does too."""
    states = plan(((1, 1), (1, 4)), ((4, 1), (4, 4)))
    v = first_violation(example_scene, states)
    cause = cause_of(example_scene, states, v)
    box = widen(example_scene, states, cause)
    assert math.prod(hi - lo + 1 for lo, hi in box.values()) > 1
    assert all(member_fails(example_scene, cause, m) for m in members(box))


def test_the_shipped_task_s_box_is_the_one_its_refinement_log_shows(payload_scene):
    """The box of the shipped task's first violation (the payload carried past the post), as
    ``cplus plan domains/payload/payload.cp`` prints it: the plans found depend on exactly
    which motions a nogood forbids, so growing must not change with its implementation."""
    states = [carried((4, 2), (4, 7)), carried((8, 2), (8, 7))]
    v = first_violation(payload_scene, states)
    assert v.kind is ViolationKind.PAYLOAD_COLLISION
    box = widen(payload_scene, states, cause_of(payload_scene, states, v))
    assert box == {(0, "pl1", 0): (1, 6), (0, "pl1", 1): (0, 4), (0, "pl2", 0): (3, 5), (0, "pl2", 1): (6, 7),
                   (1, "pl1", 0): (7, 9), (1, "pl1", 1): (1, 3), (1, "pl2", 0): (7, 9), (1, "pl2", 1): (6, 7)}


def test_causes_over_several_motions_or_holders_are_not_widened(example_scene):
    states = plan(((1, 1), (1, 4)), ((4, 1), (4, 4)))
    for cause in (Cause(("r1",), 0, 1, holds=True), Cause(("r1",), 0, 2)):
        states3 = states + states[-1:]
        box = widen(example_scene, states3, cause)
        assert all(lo == hi for lo, hi in box.values())


@given(motion=payload_motions())
@settings(max_examples=60)
def test_the_vectorised_payload_test_never_says_fail_when_the_checker_does_not(payload_scene, motion):
    a1, a2, b1, b2 = (np.array([p], dtype=float) for p in motion)
    shrunk = [o.polygon.buffer(-1e-6, join_style="mitre") for o in payload_scene.obstacles]
    low, high = payload_scene.payload.length_sq_band
    says = bool(payload_motions_fail(a1, a2, b1, b2, shrunk, low, high)[0])
    found = check_motion(payload_scene, 0, carried(motion[0], motion[1]), carried(motion[2], motion[3]))
    checker = any(v.kind in PAYLOAD_KINDS for v in found)
    assert not says or checker


@given(motions=st.lists(payload_motions(), min_size=1, max_size=12))
@settings(max_examples=60)
def test_asking_whether_every_motion_fails_is_asking_each(payload_scene, motions):
    """Widening only asks "does every motion of this slab fail?", and stops at the first clean
    one; the answer must be the per-motion test's, whatever the slab."""
    from trajectory.generalize import MARGIN, _payload_test
    rows = np.array([[*a1, *a2, *b1, *b2] for a1, a2, b1, b2 in motions], dtype=float)
    each = payload_motions_fail(rows[:, 0:2], rows[:, 2:4], rows[:, 4:6], rows[:, 6:8],
                                payload_scene.workspace.shrunk(MARGIN), *payload_scene.payload.length_sq_band)
    assert _payload_test(payload_scene, 1, [0, 1])(rows) is bool(each.all())


# ---------------------------------------------------------------------------- pre-check


def test_the_pre_check_is_the_checker_one_motion_at_a_time(example_scene):
    scene = example_scene
    found = {(b.robot, b.points) for b in bad_single_body_motions(scene)}
    points = [(float(x), float(y)) for x, y in scene.grid.points()]
    expected = set()
    for robot in scene.robots:
        good = []
        for p in points:
            if not choices_at(robot.arm, *p) or scene.obstacles_met(*p, *p):
                expected.add((robot.name, (p,)))
            else:
                good.append(p)
        for p, q in itertools.permutations(good, 2):
            if scene.obstacles_met(*p, *q) or not surviving_choices(robot.arm, choices_at(robot.arm, *p), p, q)[0]:
                expected.add((robot.name, (p, q)))
    assert found == expected
    assert {(b.robot, b.points) for b in bad_single_body_motions(scene, pairs=False)} == \
        {e for e in expected if len(e[1]) == 1}


def test_payload_turns_fail_wherever_they_happen(payload_scene):
    pairs = failing_length_pairs(payload_scene)
    assert ((0, 5), (3, 4)) in pairs and ((0, 5), (0, 5)) not in pairs
    low, high = payload_scene.payload.length_sq_band
    vectors = {d for pair in pairs for d in pair}
    assert all(low <= dx * dx + dy * dy <= high for dx, dy in vectors)
    listed = set(pairs)
    for d0, d1 in itertools.product(sorted(vectors), repeat=2):
        for a1, b1 in (((0, 0), (0, 0)), ((3, 1), (5, 2)), ((7, -1), (6, 0))):
            a2, b2 = (a1[0] + d0[0], a1[1] + d0[1]), (b1[0] + d1[0], b1[1] + d1[1])
            found = check_motion(payload_scene, 0, carried(a1, a2), carried(b1, b2))
            length = any(v.kind is ViolationKind.PAYLOAD_LENGTH for v in found)
            assert length == ((d0, d1) in listed), (d0, d1, a1, b1)
