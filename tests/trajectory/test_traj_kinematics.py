"""Kinematics: FK(IK(p)) = p, the paper's equations, branches, limits along segments."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from traj_helpers import arm_holds, segment_exit_reference

from trajectory import Arm, BranchChoice, UnreachableError, forward, ik_solutions, inverse
from trajectory.geometry import lerp
from trajectory.kinematics import choices_at, point_problem, segment_exit

PAPER_ARM = Arm((0.0, 0.0), (1.0, 0.0), 6.0, (-20.0, 20.0), (math.radians(-179), math.radians(179)))


@st.composite
def arms(draw: st.DrawFn) -> Arm:
    angle = draw(st.floats(0, 2 * math.pi))
    return Arm((draw(st.floats(-10, 10)), draw(st.floats(-10, 10))), (math.cos(angle), math.sin(angle)),
               draw(st.floats(0.5, 10)), (-50.0, 50.0), (-4.0, 2.0))


class TestInverse:
    def test_paper_equations(self) -> None:
        """s = x -+ sqrt(l^2 - y^2), theta = atan2(y, +-sqrt(l^2 - y^2)) with coupled signs."""
        x, y, arm_len = 2.0, 3.0, 6.0
        root = math.sqrt(arm_len * arm_len - y * y)
        plus, minus = ik_solutions(PAPER_ARM, x, y)
        assert plus.s == pytest.approx(x - root)
        assert plus.theta_rad == pytest.approx(math.atan2(y, root))
        assert minus.s == pytest.approx(x + root)
        assert minus.theta_rad == pytest.approx(math.atan2(y, -root))
        for sol in (plus, minus):  # (1) and (2)
            assert sol.s + arm_len * math.cos(sol.theta_rad) == pytest.approx(x)
            assert arm_len * math.sin(sol.theta_rad) == pytest.approx(y)

    def test_branches_meet_at_full_reach(self) -> None:
        plus, minus = ik_solutions(PAPER_ARM, 1.0, 6.0)
        assert plus.s == pytest.approx(minus.s) == pytest.approx(1.0)
        assert plus.theta_rad == pytest.approx(minus.theta_rad) == pytest.approx(math.pi / 2)

    @settings(max_examples=300)
    @given(arms(), st.floats(-30, 30), st.floats(-1, 1), st.sampled_from([1, -1]), st.integers(-2, 2))
    def test_fk_of_ik_is_identity(self, arm: Arm, along: float, frac: float, branch: int,
                                  turns: int) -> None:
        """Any point within reach, on either branch and any lift: FK(IK(p)) = p."""
        (dx, dy), (nx, ny) = arm.rail_dir, arm.rail_normal
        across = frac * arm.length
        x = arm.rail_origin[0] + along * dx + across * nx
        y = arm.rail_origin[1] + along * dy + across * ny
        s, theta = inverse(arm, x, y, BranchChoice(branch, turns))
        fx, fy = forward(arm, s, theta)
        assert float(fx) == pytest.approx(x, abs=1e-9 * max(1.0, abs(x)))
        assert float(fy) == pytest.approx(y, abs=1e-9 * max(1.0, abs(y)))
        assert math.cos(float(theta)) * branch >= -1e-12  # the branch is the sign of cos(theta)

    @given(arms(), st.floats(-30, 30), st.floats(1.001, 50), st.sampled_from([1, -1]))
    def test_out_of_reach_raises_never_nan(self, arm: Arm, along: float, frac: float, branch: int) -> None:
        (dx, dy), (nx, ny) = arm.rail_dir, arm.rail_normal
        across = frac * arm.length
        assume(across - arm.length > 1e-6 * max(1.0, arm.length))
        x = arm.rail_origin[0] + along * dx + across * nx
        y = arm.rail_origin[1] + along * dy + across * ny
        with pytest.raises(UnreachableError, match=r"out of reach: it is .* from the rail, the arm is"):
            inverse(arm, x, y, BranchChoice(branch))

    def test_vectorised_and_a_rounding_hair_beyond_reach(self) -> None:
        xs = np.array([0.0, 1.0, 2.0])
        ys = np.array([0.0, 6.0 + 1e-12, -3.0])
        s, theta = inverse(PAPER_ARM, xs, ys, BranchChoice(1))
        assert not np.isnan(s).any() and not np.isnan(theta).any()
        assert theta[1] == pytest.approx(math.pi / 2)

    def test_rotated_rail(self) -> None:
        """A vertical rail at x = 3 running up, arm angle from the rail direction."""
        arm = Arm((3.0, 0.0), (0.0, 1.0), 2.0, (-10.0, 10.0), (-3.0, 3.0))
        s, theta = inverse(arm, 2.0, 5.0, BranchChoice(1))
        # the normal points to -x; across = 1, so theta = 30 deg and s = 5 - sqrt(3)
        assert float(theta) == pytest.approx(math.pi / 6)
        assert float(s) == pytest.approx(5 - math.sqrt(3))


class TestLimits:
    ARM = Arm((0.0, -1.0), (1.0, 0.0), 3.0, (-4.0, 10.0), (math.radians(5), math.radians(175)))

    def test_choices_at(self) -> None:
        assert choices_at(self.ARM, 4, 1) == (BranchChoice(1, 0), BranchChoice(-1, 0))
        assert choices_at(self.ARM, -4, 1) == (BranchChoice(-1, 0),)   # +1 needs s < -4
        assert choices_at(self.ARM, 4, 3) == ()                        # beyond reach
        assert choices_at(self.ARM, 4, -1) == ()                       # theta = 0 or 180
        assert point_problem(self.ARM, 4, 3, 1) == (True, "4 from the rail, beyond the arm's 3")

    def test_lifted_angles_for_an_arm_pointing_down(self) -> None:
        arm = Arm((0.0, 5.0), (1.0, 0.0), 3.0, (-4.0, 10.0), (math.radians(-175), math.radians(-5)))
        assert choices_at(arm, 4, 3) == (BranchChoice(1, 0), BranchChoice(-1, -1))
        s, theta = inverse(arm, 4, 3, BranchChoice(-1, -1))
        assert math.degrees(float(theta)) == pytest.approx(-180 + math.degrees(math.asin(2 / 3)))

    def test_segment_leaving_s_limit_mid_way(self) -> None:
        """Branch -1 puts the carriage ahead of the hand: s hits 10 before the hand does."""
        exit_ = segment_exit(self.ARM, (4.0, 0.0), (9.0, 0.0), BranchChoice(-1))
        root = math.sqrt(9 - 1)
        assert exit_ is not None and not exit_.out_of_reach
        assert exit_.u == pytest.approx((10 - root - 4) / 5)
        assert exit_.point[0] == pytest.approx(10 - root)
        assert "s leaves its limits [-4, 10]" in exit_.reason
        assert segment_exit(self.ARM, (4.0, 0.0), (9.0, 0.0), BranchChoice(1)) is None

    def test_s_leaves_its_limit_only_between_two_feasible_ends(self) -> None:
        """On branch +1, s(u) = along(u) - sqrt(l^2 - across(u)^2) is convex: its minimum
        can lie strictly inside the segment, below s_min, while both ends are fine."""
        p0, p1 = (-3.2, 1.9), (-0.5, -0.7)
        assert BranchChoice(1) in choices_at(self.ARM, *p0)
        assert BranchChoice(1) in choices_at(self.ARM, *p1)
        exit_ = segment_exit(self.ARM, p0, p1, BranchChoice(1))
        assert exit_ is not None and not exit_.out_of_reach
        assert 0.0 < exit_.u < 0.5 and "s leaves its limits [-4, 10]" in exit_.reason
        s, _ = inverse(self.ARM, *exit_.point, BranchChoice(1))
        assert float(s) == pytest.approx(-4.0)  # the exit is exactly where s reaches its limit

    def test_theta_cannot_wrap_through_the_limit(self) -> None:
        """Limits [-170, 170]: passing from above the rail to below on branch -1 crosses 180."""
        arm = Arm((0.0, 0.0), (1.0, 0.0), 3.0, (-10.0, 10.0), (math.radians(-170), math.radians(170)))
        above, below = (-2.0, 1.0), (-2.0, -1.0)
        assert BranchChoice(-1, 0) in choices_at(arm, *above)
        exit_ = segment_exit(arm, above, below, BranchChoice(-1, 0))
        assert exit_ is not None and "theta leaves its limits [-170, 170]" in exit_.reason
        assert exit_.point[1] == pytest.approx(3 * math.sin(math.radians(10)))
        assert segment_exit(arm, above, below, BranchChoice(1, 0)) is None  # through 0 deg: fine

    @settings(max_examples=300)
    @given(st.tuples(st.floats(-6, 14), st.floats(-1.5, 2.5)),
           st.tuples(st.floats(-6, 14), st.floats(-1.5, 2.5)),
           st.sampled_from([1, -1]))
    # at exactly full reach (across = l all along) s = S is a tangent, a double root whose
    # discriminant comes out a few ulps below 0: the reference once dropped it
    @example(p0=(2.0, 2.0), p1=(-4.087524067547838, 2.0), branch=1)
    def test_segment_exit_against_an_exact_reference(self, p0, p1, branch) -> None:
        """The exit is where the reference (IK written out, boundaries solved in closed form)
        says: never early, never late, never missed, never spurious."""
        arm = self.ARM
        choice = BranchChoice(branch)
        exit_ = segment_exit(arm, p0, p1, choice)
        expected = segment_exit_reference(arm, p0, p1, choice)
        if expected is None:
            assert exit_ is None
        else:
            assert exit_ is not None and exit_.u == pytest.approx(expected, abs=1e-7)
            assert exit_.point == pytest.approx(lerp(p0, p1, exit_.u), abs=1e-9)
        # the reference itself against 1001 samples: feasible before the exit, not right after
        us = np.linspace(0, 1, 1001)
        ok = [arm_holds(arm, choice, *lerp(p0, p1, u)) for u in us]
        first_bad = next((u for u, good in zip(us, ok) if not good), None)
        if first_bad is not None:
            assert expected is not None and expected <= first_bad

    @settings(max_examples=300)
    @given(arms(), *[st.tuples(st.floats(-60, 60), st.floats(-1.5, 1.5)) for _ in range(2)],
           st.sampled_from([1, -1]), st.integers(-1, 1))
    def test_segment_exit_on_any_arm_against_the_reference(self, arm: Arm, q0, q1, branch, turns) -> None:
        """Rotated rails, any length, lifted angles: the same exact agreement."""
        (dx, dy), (nx, ny) = arm.rail_dir, arm.rail_normal

        def xy(q):
            along, frac = q
            return (arm.rail_origin[0] + along * dx + frac * arm.length * nx,
                    arm.rail_origin[1] + along * dy + frac * arm.length * ny)
        p0, p1 = xy(q0), xy(q1)
        choice = BranchChoice(branch, turns)
        exit_ = segment_exit(arm, p0, p1, choice)
        expected = segment_exit_reference(arm, p0, p1, choice)
        if expected is None:
            assert exit_ is None
        else:
            assert exit_ is not None and exit_.u == pytest.approx(expected, abs=1e-7)


class TestMemo:
    """`choices_at` and `segment_exit` remember their answers (the refinement loop asks the same
    questions plan after plan); a remembered answer must be the answer."""

    @settings(max_examples=80)
    @given(arms(), st.lists(st.tuples(st.integers(-8, 8), st.integers(-8, 8)), min_size=2, max_size=6),
           st.sampled_from([1, -1]))
    def test_remembered_answers_are_the_answers(self, arm: Arm, points, branch: int) -> None:
        from trajectory import kinematics
        fresh_choices = kinematics._choices_at.__wrapped__
        fresh_exit = kinematics._segment_exit.__wrapped__
        for _ in range(2):   # the second round is answered from memory
            for (x0, y0), (x1, y1) in zip(points, points[1:]):
                p0, p1 = (x0, y0), (float(x1), float(y1))        # ints and floats are the same point
                assert choices_at(arm, x0, y0) == fresh_choices(arm, float(x0), float(y0))
                choice = BranchChoice(branch, 0)
                assert segment_exit(arm, p0, p1, choice) == fresh_exit(arm, (float(x0), float(y0)), p1, choice)

    def test_arms_that_differ_are_asked_apart(self) -> None:
        near = Arm((0.0, 0.0), (1.0, 0.0), 3.0, (-5.0, 5.0), (0.1, 3.0))
        far = Arm((0.0, 0.0), (1.0, 0.0), 6.0, (-5.0, 5.0), (0.1, 3.0))
        assert choices_at(near, 0, 4) == ()
        assert choices_at(far, 0, 4) != ()
