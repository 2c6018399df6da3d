"""Kinematics to the letter: the arm's validation, the reasons a branch cannot hold a point or
follow a segment (exact texts and values), and the limits themselves counting as inside."""

from __future__ import annotations

import math

import pytest

from trajectory import Arm, BranchChoice, JointState, TrajectoryError, UnreachableError, ik_solutions, inverse
from trajectory.geometry import EPS
from trajectory.kinematics import SegmentExit, choices_at, point_problem, segment_exit, surviving_choices

ARM = Arm((0.0, -1.0), (1.0, 0.0), 3.0, (-4.0, 10.0), (math.radians(5), math.radians(175)))


@pytest.mark.parametrize("kwargs, message", [
    ({"rail_dir": (1.0, 0.1)}, "rail direction (1.0, 0.1) is not a unit vector"),
    ({"length": 0.0}, "arm length must be positive, not 0.0"),
    ({"length": math.inf}, "arm length must be positive, not inf"),
    ({"s_limits": (2.0, 2.0)}, "s limits (2.0, 2.0) are not increasing"),
    ({"theta_limits_rad": (1.0, 1.0)}, "theta limits (1.0, 1.0) must increase and span less than a turn"),
    ({"theta_limits_rad": (0.0, 2 * math.pi)}, "must increase and span less than a turn"),
])
def test_an_arm_that_cannot_exist_is_refused(kwargs, message):
    fields = {"rail_origin": (0.0, 0.0), "rail_dir": (1.0, 0.0), "length": 3.0, "s_limits": (-1.0, 1.0),
              "theta_limits_rad": (0.0, 1.0)} | kwargs
    with pytest.raises(TrajectoryError) as info:
        Arm(**fields)
    assert message in str(info.value)


def test_just_inside_the_arms_own_limits_is_an_arm():
    Arm((0.0, 0.0), (0.6, 0.8), 1e-9, (-1.0, -0.999), (0.0, 2 * math.pi - 1e-9))


def test_the_rail_frame_and_scale():
    arm = Arm((1.0, 2.0), (0.0, 1.0), 2.0, (-30.0, 5.0), (0.0, 1.0))
    assert arm.rail_normal == (-1.0, 0.0)
    along, across = arm.rail_frame(3.0, 7.0)
    assert (float(along), float(across)) == (5.0, -2.0)
    assert arm.scale == 30.0
    assert Arm((0.0, -12.0), (1.0, 0.0), 2.0, (-3.0, 5.0), (0.0, 1.0)).scale == 12.0
    assert Arm((0.0, 0.0), (1.0, 0.0), 0.5, (-0.5, 0.5), (0.0, 1.0)).scale == 1.0


def test_branch_choices_print_their_turns_only_when_there_are_some():
    assert [str(c) for c in (BranchChoice(1), BranchChoice(-1, -1), BranchChoice(1, 2))] == [
        "branch +1", "branch -1 (turns -1)", "branch +1 (turns +2)"]


def test_both_ik_solutions():
    hand_ahead, hand_behind = ik_solutions(ARM, 1, 1)
    root = math.sqrt(5)
    assert hand_ahead == JointState(pytest.approx(1 - root), pytest.approx(math.atan2(2, root)))
    assert hand_behind == JointState(pytest.approx(1 + root), pytest.approx(math.atan2(2, -root)))


def test_the_first_point_out_of_reach_is_named():
    with pytest.raises(UnreachableError) as info:
        inverse(ARM, [1, 2, 3], [0, 4, 5], BranchChoice(1))
    assert str(info.value) == "error: point (2, 4) is out of reach: it is 5 from the rail, the arm is 3 long"
    with pytest.raises(TrajectoryError, match="^error: IK branch must be \\+1 or -1, not 0$"):
        inverse(ARM, 1, 1, BranchChoice(0))


def test_why_a_branch_cannot_hold_a_point():
    assert point_problem(ARM, 1, 1, 1) is None
    assert point_problem(ARM, 1, -0.9, 1) == (False, "theta = 1.91 deg is outside the limits [5, 175]")
    assert point_problem(ARM, 1, -0.9, -1) == (False, "theta = 178.1 deg is outside the limits [5, 175]")
    assert point_problem(ARM, -4, 1, 1) == (False, "s = -6.236 is outside the limits [-4, 10]")
    assert point_problem(ARM, 12, 1, -1) == (False, "s = 14.24 is outside the limits [-4, 10]")
    assert point_problem(ARM, 1, 2.5, 1) == (True, "3.5 from the rail, beyond the arm's 3")
    assert point_problem(ARM, 1, -4.5, -1) == (True, "3.5 from the rail, beyond the arm's 3")


def test_the_limits_themselves_are_inside():
    across = 3 * math.sin(math.radians(5))
    assert choices_at(ARM, 0, -1 + across) == (BranchChoice(1), BranchChoice(-1))
    assert choices_at(ARM, 0, -1 + across * 0.999) == ()
    # s exactly at its limits on branch +1 (s = x - sqrt(9 - 4)) and -1 (s = x + sqrt(5))
    assert BranchChoice(1) in choices_at(ARM, -4 + math.sqrt(5), 1)
    assert BranchChoice(1) not in choices_at(ARM, -4.001 + math.sqrt(5), 1)
    assert BranchChoice(-1) in choices_at(ARM, 10 - math.sqrt(5), 1)
    assert BranchChoice(-1) not in choices_at(ARM, 10.001 - math.sqrt(5), 1)
    # at exactly full reach both branches are the same pose
    assert choices_at(ARM, 4, 2) == (BranchChoice(1), BranchChoice(-1))
    assert choices_at(ARM, 4, 2 + 1e-6) == ()


@pytest.mark.parametrize("p0, p1, branch, expected", [
    ((4.0, 0.0), (9.0, 0.0), -1, SegmentExit(
        (10 - math.sqrt(8) - 4) / 5, (10 - math.sqrt(8), 0.0), False,
        "s leaves its limits [-4, 10] (10.91 at u = 0.8172)")),
    ((1.0, 1.0), (1.0, 3.5), 1, SegmentExit(
        0.4, (1.0, 2.0), True, "the point leaves the arm's reach 3 from the rail (3.75 at u = 0.7)")),
    ((1.0, 1.0), (1.0, -0.9), 1, SegmentExit(
        (2 - 3 * math.sin(math.radians(5))) / 1.9, (1.0, -1 + 3 * math.sin(math.radians(5))), False,
        "theta leaves its limits [5, 175] deg (3.454 at u = 0.9575)")),
    ((1.0, 1.0), (1.0, -0.9), -1, SegmentExit(
        (2 - 3 * math.sin(math.radians(5))) / 1.9, (1.0, -1 + 3 * math.sin(math.radians(5))), False,
        "theta leaves its limits [5, 175] deg (176.5 at u = 0.9575)")),
    ((-3.2, 1.9), (-0.5, -0.7), 1, SegmentExit(
        0.004675383072169677, (-3.187376465705142, 1.8878440040123587), False,
        "s leaves its limits [-4, 10] (-4.484 at u = 0.3829)")),
    ((1.0, 1.0), (1.0, 3.5), -1, SegmentExit(
        0.4, (1.0, 2.0), True, "the point leaves the arm's reach 3 from the rail (3.75 at u = 0.7)")),
])
def test_segment_exits_to_the_letter(p0, p1, branch, expected):
    got = segment_exit(ARM, p0, p1, BranchChoice(branch))
    assert got is not None
    assert (got.out_of_reach, got.reason) == (expected.out_of_reach, expected.reason)
    assert got.u == pytest.approx(expected.u, abs=1e-9)
    assert got.point == pytest.approx(expected.point, abs=1e-9)


def test_segments_that_end_exactly_on_a_limit_stay_inside():
    across = 3 * math.sin(math.radians(5))
    assert segment_exit(ARM, (1.0, 1.0), (1.0, -1 + across), BranchChoice(1)) is None
    assert segment_exit(ARM, (1.0, 1.0), (1.0, 2.0), BranchChoice(1)) is None   # full reach
    assert segment_exit(ARM, (0.0, 1.0), (10 - math.sqrt(5), 1.0), BranchChoice(-1)) is None
    assert segment_exit(ARM, (4.0, 2.0), (4.0, 2.0), BranchChoice(1)) is None   # standing at full reach
    assert segment_exit(ARM, (4.0, 1.0), (4.0, 1.0), BranchChoice(1)) is None


def test_an_arm_with_no_angle_on_a_branch():
    """Limits [10, 80] deg: branch -1 (angles 90..270) has none, so it fails at once."""
    arm = Arm((0.0, 0.0), (1.0, 0.0), 3.0, (-10.0, 10.0), (math.radians(10), math.radians(80)))
    assert choices_at(arm, 1, 2) == (BranchChoice(1),)
    exit_ = segment_exit(arm, (1.0, 2.0), (2.0, 2.0), BranchChoice(-1))
    assert exit_ is not None and exit_.u == 0.0 and "theta leaves its limits [10, 80] deg" in exit_.reason
    assert segment_exit(arm, (1.0, 2.0), (2.0, 2.0), BranchChoice(1)) is None


def test_surviving_choices_keep_their_order_and_say_why_the_others_died():
    alive, dead = surviving_choices(ARM, choices_at(ARM, 4, 1), (4, 1), (9, 1))
    assert alive == (BranchChoice(1),)
    assert [(c, e.reason) for c, e in dead] == [
        (BranchChoice(-1), "s leaves its limits [-4, 10] (10.62 at u = 0.8764)")]
    assert dead[0][1].u == pytest.approx((10 - math.sqrt(5) - 4) / 5)
    alive, dead = surviving_choices(ARM, (BranchChoice(-1), BranchChoice(1)), (4, 1), (5, 1))
    assert alive == (BranchChoice(-1), BranchChoice(1)) and dead == ()


def test_a_hair_beyond_full_reach_is_full_reach():
    """Within the reach tolerance l^2 - across^2 may come out a little negative: it counts as 0
    (no square root of a negative number)."""
    for dy in (1e-9, 5e-9):
        assert point_problem(ARM, 4, 2 + dy, 1) is None and point_problem(ARM, 4, 2 + dy, -1) is None
        assert choices_at(ARM, 4, 2 + dy) == (BranchChoice(1), BranchChoice(-1))


def test_limits_that_end_or_begin_exactly_at_full_reach():
    """At full reach both branches point at 90 degrees. The limits count within EPS: an upper
    limit EPS below 90 degrees, or a lower one EPS above, still holds the arm there, standing
    or moving."""
    below = Arm((0.0, 0.0), (1.0, 0.0), 3.0, (-10.0, 10.0), (0.0, 0.5 * math.pi - EPS))
    assert choices_at(below, 1, 3) == (BranchChoice(1), BranchChoice(-1))
    above = Arm((0.0, 0.0), (1.0, 0.0), 3.0, (-10.0, 10.0), (0.5 * math.pi + EPS, 0.5 * math.pi + 1.0))
    assert choices_at(above, 1, 3) == (BranchChoice(1), BranchChoice(-1))
    for choice in choices_at(above, 1, 3):
        assert segment_exit(above, (1.0, 3.0), (1.0, 3.0), choice) is None
