"""The continuous checker's reports to the letter: kind, time, point, subject, obstacle, message
and cause of every violation of small hand-made plans, one per branch of the checker."""

from __future__ import annotations

import pytest
from traj_helpers import carried, plan

from trajectory import StepState, ViolationKind, all_violations, first_violation, parse_scene
from trajectory.checker import Cause, cause_of, check_motion
from trajectory.scene import EXAMPLE_SCENE

K = ViolationKind

# the example scene with a second obstacle listed first ("wall", x in [4.5, 5], y in [0.5, 1.5]):
# the first contact must win, not the first obstacle
WALL_SCENE = EXAMPLE_SCENE.replace(
    '[[obstacles]]\nname = "post"',
    '[[obstacles]]\nname = "wall"\npoints = [[4.5, 0.5], [5, 0.5], [5, 1.5], [4.5, 1.5], [4.5, 0.5]]\n'
    '[[obstacles]]\nname = "post"')

PLANS = {
    "two": plan(((1, 1), (1, 4)), ((6, 1), (6, 4))),
    "back": plan(((6, 1), (6, 4)), ((1, 1), (1, 4))),
    "long": plan(((1, 1), (1, 4)), ((1, 1), (1, 4.5))),
    "longer": plan(((1, 2), (1, 4)), ((1, 2), (1, 5.5))),
    "joint": plan(((1, -0.9), (1, 4)), ((1, 1), (1, 4))),
    "unreach3": plan(((1, 1), (1, 4)), ((1, 3), (1, 4)), ((1, 3.5), (1, 4))),
    "unreach3same": plan(((1, 1), (1, 4)), ((1, 3), (1, 4)), ((1, 3), (1, 4))),
    "length4": plan(((1, 1), (1, 4)), ((1, 1), (1, 1.0123))),    # a length printed to 4 decimals
    "s_both": plan(((12.5, 1), (1, 4)), ((12.5, 1), (1, 4))),     # s out of limits on both branches
    # from a point no branch holds, the branches are those of the next point, (-3, 1): -1 only
    "reset": plan(((1, 1), (1, 4)), ((1, 3), (1, 4)), ((-3, 1), (1, 4)), ((8, 1), (1, 4))),
    "oddstep": [carried((1, 1), (1, 4)), carried((1, 1), (1, 4)),
                StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (1, 3)}, {"pl1": "r1", "pl2": "r2"})],
    "lastdetached": [carried((1, 1), (1, 4)),
                     StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (1, 3)},
                               {"pl1": "r1", "pl2": "r2"})],
}

# (step, kind, u, point, subject, obstacle, message, cause) of every violation, in order
EXPECTED = {
    'two': [
        (0, K.EFFECTOR_COLLISION, 0.2, (2.0, 1.0), 'r1', 'post',
         "robot r1's end-effector, moving (1, 1) -> (6, 1) (step 0 -> 1), hits obstacle 'post' at (2, 1)",
         Cause(('r1',), 0, 1)),
        (0, K.PAYLOAD_COLLISION, 0.2, (2.0, 1.0), 'payload', 'post',
         "the payload, carried from (1, 1)-(1, 4) to (6, 1)-(6, 4) (step 0 -> 1), hits obstacle 'post' at (2, 1) between the states, at u = 0.2",
         Cause(('pl1', 'pl2'), 0, 1)),
    ],
    'back': [
        (0, K.EFFECTOR_COLLISION, 0.2, (5.0, 1.0), 'r1', 'wall',
         "robot r1's end-effector, moving (6, 1) -> (1, 1) (step 0 -> 1), hits obstacle 'wall' at (5, 1)",
         Cause(('r1',), 0, 1)),
        (0, K.PAYLOAD_COLLISION, 0.2, (5.0, 1.0), 'payload', 'wall',
         "the payload, carried from (6, 1)-(6, 4) to (1, 1)-(1, 4) (step 0 -> 1), hits obstacle 'wall' at (5, 1) between the states, at u = 0.2",
         Cause(('pl1', 'pl2'), 0, 1)),
    ],
    'long': [
        (0, K.PAYLOAD_LENGTH, 0.324555, (1.0, 2.581139), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 1)-(1, 4) to (1, 1)-(1, 4.5) (step 0 -> 1): from u = 0.3246, reaching 12.25 (length 3.5) at u = 1",
         Cause(('pl1', 'pl2'), 1, 1)),
    ],
    'longer': [
        (0, K.PAYLOAD_LENGTH, 0.0, (1.0, 3.0), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 2)-(1, 4) to (1, 2)-(1, 5.5) (step 0 -> 1): from u = 0, reaching 4 (length 2) at u = 0",
         Cause(('pl1', 'pl2'), 0, 0)),
        (0, K.JOINT_LIMIT, 0.492355, (1.0, 4.738533), 'r2', None,
         'robot r2 cannot stay within its joint limits moving (1, 4) -> (1, 5.5) (step 0 -> 1): branch +1 at u = 0.4924, (1, 4.739): theta leaves its limits [-175, -5] deg (2.278 at u = 0.7462); branch -1 (turns -1) at u = 0.4924, (1, 4.739): theta leaves its limits [-175, -5] deg (-182.3 at u = 0.7462)',
         Cause(('r2',), 1, 1)),
    ],
    'joint': [
        (0, K.JOINT_LIMIT, 0.0, (1.0, -0.9), 'r1', None,
         'robot r1 cannot hold its end-effector at (1, -0.9) (step 0): branch +1: theta = 1.91 deg is outside the limits [5, 175]; branch -1: theta = 178.1 deg is outside the limits [5, 175]',
         Cause(('r1',), 0, 0)),
        (0, K.PAYLOAD_LENGTH, 0.0, (1.0, 1.55), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, -0.9)-(1, 4) to (1, 1)-(1, 4) (step 0 -> 1): from u = 0, reaching 24.01 (length 4.9) at u = 0",
         Cause(('pl1', 'pl2'), 0, 0)),
    ],
    'unreach3': [
        (0, K.PAYLOAD_LENGTH, 0.085786, (1.0, 2.585786), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 1)-(1, 4) to (1, 3)-(1, 4) (step 0 -> 1): from u = 0.0858, reaching 1 (length 1) at u = 1",
         Cause(('pl1', 'pl2'), 1, 1)),
        (0, K.OUT_OF_REACH, 0.5, (1.0, 2.0), 'r1', None,
         "robot r1 leaves its reach moving (1, 1) -> (1, 3) (step 0 -> 1): every branch at u = 0.5, (1, 2): the point leaves the arm's reach 3 from the rail (3.5 at u = 0.75)",
         Cause(('r1',), 1, 1)),
        (1, K.OUT_OF_REACH, 0.0, (1.0, 3.0), 'r1', None,
         "robot r1 cannot hold its end-effector at (1, 3) (step 1): 4 from the rail, beyond the arm's 3",
         Cause(('r1',), 1, 1)),
        (1, K.PAYLOAD_LENGTH, 0.0, (1.0, 3.5), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 3)-(1, 4) to (1, 3.5)-(1, 4) (step 1 -> 2): from u = 0, reaching 0.25 (length 0.5) at u = 1",
         Cause(('pl1', 'pl2'), 1, 1)),
        (1, K.OUT_OF_REACH, 1.0, (1.0, 3.5), 'r1', None,
         "robot r1 cannot hold its end-effector at (1, 3.5) (step 2): 4.5 from the rail, beyond the arm's 3",
         Cause(('r1',), 1, 1)),
    ],
    'unreach3same': [
        (0, K.PAYLOAD_LENGTH, 0.085786, (1.0, 2.585786), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 1)-(1, 4) to (1, 3)-(1, 4) (step 0 -> 1): from u = 0.0858, reaching 1 (length 1) at u = 1",
         Cause(('pl1', 'pl2'), 1, 1)),
        (0, K.OUT_OF_REACH, 0.5, (1.0, 2.0), 'r1', None,
         "robot r1 leaves its reach moving (1, 1) -> (1, 3) (step 0 -> 1): every branch at u = 0.5, (1, 2): the point leaves the arm's reach 3 from the rail (3.5 at u = 0.75)",
         Cause(('r1',), 1, 1)),
        (1, K.OUT_OF_REACH, 0.0, (1.0, 3.0), 'r1', None,
         "robot r1 cannot hold its end-effector at (1, 3) (step 1): 4 from the rail, beyond the arm's 3",
         Cause(('r1',), 1, 1)),
        (1, K.PAYLOAD_LENGTH, 0.0, (1.0, 3.5), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 3)-(1, 4) to (1, 3)-(1, 4) (step 1 -> 2): from u = 0, reaching 1 (length 1) at u = 0",
         Cause(('pl1', 'pl2'), 1, 1)),
    ],
    'length4': [
        (0, K.PAYLOAD_LENGTH, 0.057426, (1.0, 2.414214), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 1)-(1, 4) to (1, 1)-(1, 1.012) (step 0 -> 1): from u = 0.0574, reaching 0.0002 (length 0.0123) at u = 1",
         Cause(('pl1', 'pl2'), 1, 1)),
        (0, K.OUT_OF_REACH, 0.669411, (1.0, 2.0), 'r2', None,
         "robot r2 leaves its reach moving (1, 4) -> (1, 1.012) (step 0 -> 1): every branch at u = 0.6694, (1, 2): the point leaves the arm's reach 3 from the rail (3.494 at u = 0.8347)",
         Cause(('r2',), 1, 1)),
    ],
    's_both': [
        (0, K.JOINT_LIMIT, 0.0, (12.5, 1.0), 'r1', None,
         'robot r1 cannot hold its end-effector at (12.5, 1) (step 0): branch +1: s = 10.26 is outside the limits [-4, 10]; branch -1: s = 14.74 is outside the limits [-4, 10]',
         Cause(('r1',), 0, 0)),
        (0, K.PAYLOAD_LENGTH, 0.0, (6.75, 2.5), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (12.5, 1)-(1, 4) to (12.5, 1)-(1, 4) (step 0 -> 1): from u = 0, reaching 141.2 (length 11.88) at u = 1",
         Cause(('pl1', 'pl2'), 0, 0)),
    ],
    'reset': [
        (0, K.PAYLOAD_LENGTH, 0.085786, (1.0, 2.585786), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 1)-(1, 4) to (1, 3)-(1, 4) (step 0 -> 1): from u = 0.0858, reaching 1 (length 1) at u = 1",
         Cause(('pl1', 'pl2'), 1, 1)),
        (0, K.OUT_OF_REACH, 0.5, (1.0, 2.0), 'r1', None,
         "robot r1 leaves its reach moving (1, 1) -> (1, 3) (step 0 -> 1): every branch at u = 0.5, (1, 2): the point leaves the arm's reach 3 from the rail (3.5 at u = 0.75)",
         Cause(('r1',), 1, 1)),
        (1, K.OUT_OF_REACH, 0.0, (1.0, 3.0), 'r1', None,
         "robot r1 cannot hold its end-effector at (1, 3) (step 1): 4 from the rail, beyond the arm's 3",
         Cause(('r1',), 1, 1)),
        (1, K.PAYLOAD_LENGTH, 0.0, (1.0, 3.5), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 3)-(1, 4) to (-3, 1)-(1, 4) (step 1 -> 2): from u = 0, reaching 1 (length 1) at u = 0",
         Cause(('pl1', 'pl2'), 1, 1)),
        (2, K.PAYLOAD_LENGTH, 0.0, (-1.0, 2.5), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (-3, 1)-(1, 4) to (8, 1)-(1, 4) (step 2 -> 3): from u = 0, reaching 58 (length 7.616) at u = 1",
         Cause(('pl1', 'pl2'), 2, 2)),
        (2, K.EFFECTOR_COLLISION, 0.454545, (2.0, 1.0), 'r1', 'post',
         "robot r1's end-effector, moving (-3, 1) -> (8, 1) (step 2 -> 3), hits obstacle 'post' at (2, 1)",
         Cause(('r1',), 2, 3)),
        (2, K.PAYLOAD_COLLISION, 0.454545, (2.0, 1.0), 'payload', 'post',
         "the payload, carried from (-3, 1)-(1, 4) to (8, 1)-(1, 4) (step 2 -> 3), hits obstacle 'post' at (2, 1) between the states, at u = 0.4545",
         Cause(('pl1', 'pl2'), 2, 3)),
        (2, K.JOINT_LIMIT, 0.978539, (7.763932, 1.0), 'r1', None,
         'robot r1 cannot stay within its joint limits moving (-3, 1) -> (8, 1) (step 2 -> 3): branch -1 at u = 0.9785, (7.764, 1): s leaves its limits [-4, 10] (10.12 at u = 0.9893)',
         Cause(('r1',), 2, 3)),
    ],
    'oddstep': [
        (1, K.DETACHED, 0.0, (1.0, 4.0), 'pl2', None,
         'payload end pl2 is held by r2 at step 1 but does not follow it to step 2: r2 moves to (1, 4), pl2 goes to (1, 3)',
         Cause(('r1', 'r2', 'pl1', 'pl2'), 1, 2, holds=True)),
        (1, K.PAYLOAD_LENGTH, 0.171573, (1.0, 2.414214), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 1)-(1, 4) to (1, 1)-(1, 3) (step 1 -> 2): from u = 0.1716, reaching 4 (length 2) at u = 1",
         Cause(('pl1', 'pl2'), 2, 2)),
        (1, K.DETACHED, 1.0, (1.0, 3.0), 'pl2', None,
         'step 2: payload end pl2 is said to be held by r2, but pl2 is at (1, 3) and r2 at (1, 4)',
         Cause(('r1', 'r2', 'pl1', 'pl2'), 1, 2, holds=True)),
    ],
    'lastdetached': [
        (0, K.DETACHED, 0.0, (1.0, 4.0), 'pl2', None,
         'payload end pl2 is held by r2 at step 0 but does not follow it to step 1: r2 moves to (1, 4), pl2 goes to (1, 3)',
         Cause(('r1', 'r2', 'pl1', 'pl2'), 0, 1, holds=True)),
        (0, K.PAYLOAD_LENGTH, 0.171573, (1.0, 2.414214), 'payload', None,
         "the payload's squared length leaves [8, 10] while carried from (1, 1)-(1, 4) to (1, 1)-(1, 3) (step 0 -> 1): from u = 0.1716, reaching 4 (length 2) at u = 1",
         Cause(('pl1', 'pl2'), 1, 1)),
        (0, K.DETACHED, 1.0, (1.0, 3.0), 'pl2', None,
         'step 1: payload end pl2 is said to be held by r2, but pl2 is at (1, 3) and r2 at (1, 4)',
         Cause(('r1', 'r2', 'pl1', 'pl2'), 0, 1, holds=True)),
    ],
}


@pytest.fixture(scope="module")
def wall_scene():
    return parse_scene(WALL_SCENE, "wall.toml")


@pytest.mark.parametrize("name", list(PLANS))
def test_every_violation_to_the_letter(wall_scene, name):
    states = PLANS[name]
    found = all_violations(wall_scene, states)
    assert [(v.step, v.kind, v.subject, v.obstacle, v.message) for v in found] == [
        (e[0], e[1], e[4], e[5], e[6]) for e in EXPECTED[name]]
    for v, e in zip(found, EXPECTED[name]):
        assert v.u == pytest.approx(e[2], abs=1e-6) and v.point == pytest.approx(e[3], abs=1e-6)
        assert cause_of(wall_scene, states, v) == e[7]
    assert first_violation(wall_scene, states) == (found[0] if found else None)


def test_a_middle_state_is_checked_once_as_the_next_motions_start(wall_scene):
    """``holds`` of the state between two motions is reported at u = 0 of the later one only."""
    bad = StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (1, 3)}, {"pl1": "r1", "pl2": "r2"})
    good = carried((1, 1), (1, 4))
    said = [(v.step, v.u) for v in all_violations(wall_scene, [good, bad, bad])
            if v.kind is K.DETACHED and "is said to be held" in v.message]
    assert said == [(1, 0.0), (1, 1.0)]
    assert [v.kind for v in check_motion(wall_scene, 0, good, bad)] == [K.DETACHED, K.PAYLOAD_LENGTH]
    assert [v.u for v in check_motion(wall_scene, 0, good, bad, last=True) if v.kind is K.DETACHED] == [0.0, 1.0]


def test_an_end_that_stays_put_unheld_and_a_detached_end_without_a_taker(wall_scene):
    a = StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (3, 3)}, {"pl1": "r1"})
    b = StepState({"r1": (2, 1), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (3, 3)}, {"pl1": "r1"})
    found = [v for v in all_violations(wall_scene, [a, b]) if v.kind is K.DETACHED]
    assert [v.message for v in found] == [
        "payload end pl1 is held by r1 at step 0 but does not follow it to step 1: r1 moves to (2, 1), "
        "pl1 goes to (1, 1)",
        "step 1: payload end pl1 is said to be held by r1, but pl1 is at (1, 1) and r1 at (2, 1)"]


def test_positions_within_rounding_are_the_same():
    scene = parse_scene(WALL_SCENE, "wall.toml")
    near = StepState({"r1": (1, 1 + 1e-12), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (1, 4)},
                     {"pl1": "r1", "pl2": "r2"})
    assert [v for v in all_violations(scene, [near, near]) if v.kind is K.DETACHED] == []
    far = StepState({"r1": (1, 1 + 1e-6), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (1, 4)},
                    {"pl1": "r1", "pl2": "r2"})
    assert [v.subject for v in all_violations(scene, [far, far]) if v.kind is K.DETACHED] == ["pl1", "pl1"]


def test_a_cause_kept_from_an_earlier_branch_starts_where_the_branch_was_chosen():
    """r1's carriage runs s in [-1, 7]; at y = 0 one branch fits x <= 4.17, the other x >= 1.83.
    From x = 0 the arm is committed to the first and cannot go on from 3 to 6."""
    text = EXAMPLE_SCENE.replace("x_max = 6", "x_max = 12").replace(
        'name = "post"\npoints = [[2, -1], [3, -1], [3, 1], [2, 1], [2, -1]]',
        'name = "far"\npoints = [[20, 20], [21, 20], [21, 21], [20, 21], [20, 20]]').replace(
        "arm_length = 3\ns_limits = [-4, 10]\ntheta_limits_deg = [5, 175]",
        "arm_length = 3\ns_limits = [-1, 7]\ntheta_limits_deg = [5, 175]")
    scene = parse_scene(text, "rail.toml")
    path = [(0, 0), (1, 0), (3, 0), (6, 0)]
    states = [carried(p, (p[0], 3)) for p in path]
    v = next(v for v in all_violations(scene, states) if v.subject == "r1")
    assert (v.kind, v.step) == (K.JOINT_LIMIT, 2)
    assert cause_of(scene, states, v) == Cause(("r1",), 1, 3)
    assert [w for w in all_violations(scene, states[2:]) if w.subject == "r1"] == []  # from 3 on: fine
    w = next(w for w in all_violations(scene, states[1:]) if w.subject == "r1")
    assert (w.step, cause_of(scene, states[1:], w)) == (1, Cause(("r1",), 0, 2))
    assert Cause(("r1",), 1, 3).span == 2 and Cause(("r1",), 2, 2).span == 0


def test_the_cause_of_a_single_state_is_that_state(wall_scene):
    states = [carried((2, 0), (2, 3))]
    assert [cause_of(wall_scene, states, v) for v in all_violations(wall_scene, states)] == [
        Cause(("r1",), 0, 0), Cause(("pl1", "pl2"), 0, 0)]


def _robot(name: str, rail_y: float, limits: str) -> str:
    return (f'[robots.{name}]\nrail_origin = [0, {rail_y}]\nrail_dir = [1, 0]\narm_length = 3\n'
            f's_limits = [-4, 10]\ntheta_limits_deg = {limits}\n'
            f'bindings = {{ x = "xpos({name})", y = "ypos({name})" }}\n'
            'motors = [ { port = "A", joint = "s", deg_per_unit = 90 },\n'
            '           { port = "B", joint = "theta", deg_per_unit = 5 } ]\n')


def test_a_cause_is_that_of_its_own_subject():
    """r1 stands in the post at step 0; r2 runs into a beam on the way: r2's cause is its
    motion, not r1's state."""
    text = EXAMPLE_SCENE.replace('[[obstacles]]\nname = "post"',
                                 '[[obstacles]]\nname = "beam"\npoints = [[4, 3], [5, 3], [5, 3.5], [4, 3.5], [4, 3]]\n'
                                 '[[obstacles]]\nname = "post"')
    scene = parse_scene(text, "beam.toml")
    states = [StepState({"r1": (2, 0), "r2": (3, 3.2)}, {"pl1": (2, 0), "pl2": (3, 3.2)}, {}),
              StepState({"r1": (2, 0), "r2": (6, 3.2)}, {"pl1": (2, 0), "pl2": (3, 3.2)}, {})]
    hits = {v.subject: v for v in all_violations(scene, states) if v.kind is K.EFFECTOR_COLLISION}
    assert sorted(hits) == ["r1", "r2"] and hits["r2"].u == pytest.approx(1 / 3)
    assert cause_of(scene, states, hits["r1"]) == Cause(("r1",), 0, 0)
    assert cause_of(scene, states, hits["r2"]) == Cause(("r2",), 0, 1)


def test_an_end_that_jumps_names_the_first_robot_it_lands_on():
    i = EXAMPLE_SCENE.index("[payload]")
    text = EXAMPLE_SCENE[:i] + _robot("r3", 5, "[-175, -5]") + _robot("r4", 5, "[-175, -5]") + EXAMPLE_SCENE[i:]
    scene = parse_scene(text, "four.toml")
    a = StepState({"r1": (1, 1), "r2": (1, 4), "r3": (4, 4), "r4": (5, 4)}, {"pl1": (1, 1), "pl2": (1, 4)},
                  {"pl1": "r1", "pl2": "r2"})
    b = StepState({"r1": (1, 1), "r2": (2, 4), "r3": (4, 4), "r4": (4, 4)}, {"pl1": (1, 1), "pl2": (4, 4)},
                  {"pl1": "r1", "pl2": "r2"})
    v = next(v for v in all_violations(scene, [a, b]) if v.kind is K.DETACHED)
    assert v.message == ("payload end pl2 is held by r2 at step 0 but does not follow it to step 1: r2 moves "
                         "to (2, 4), pl2 goes to (4, 4), to r3")


def test_causes_are_values():
    assert Cause.__dataclass_params__.frozen and "__slots__" in vars(Cause)
