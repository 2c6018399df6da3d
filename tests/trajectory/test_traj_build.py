"""From plan states to joint and motor trajectories."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from traj_helpers import CLEAN_PAYLOAD_PLAN, FIRST_PAYLOAD_PLAN, plan

from trajectory import (
    BranchChoice,
    JointLimitError,
    PlanViolationError,
    Scene,
    TrajectoryError,
    UnreachableError,
    ViolationKind,
    build_trajectory,
    forward,
    parse_scene,
)
from trajectory.build import interpolate_path
from trajectory.kinematics import choices_at
from trajectory.scene import EXAMPLE_SCENE


class TestInterpolation:
    def test_samples_and_steps(self) -> None:
        pts, step = interpolate_path([(0, 0), (2, 0), (2, 3)], 2)
        assert pts.tolist() == [[0, 0], [1, 0], [2, 0], [2, 1.5], [2, 3]]
        assert step.tolist() == [0, 0, 1, 1, 2]

    def test_single_point(self) -> None:
        pts, step = interpolate_path([(1, 1)], 5)
        assert pts.tolist() == [[1, 1]] and step.tolist() == [0]


@pytest.fixture(scope="module")
def traj(payload_scene: Scene):
    """The clean payload plan as a trajectory: 10 ticks per step, 1 s per step."""
    return build_trajectory(payload_scene, plan(*CLEAN_PAYLOAD_PLAN), points_per_step=10,
                            step_time_s=1.0, source={"domain": "domains/payload/payload.cp"})


class TestPayloadPlan:
    def test_shape_and_clock(self, traj) -> None:
        m = len(CLEAN_PAYLOAD_PLAN) - 1
        assert traj.tick_ms == 100 and traj.plan_length == m and traj.ticks == 10 * m + 1
        assert dict(traj.source) == {"domain": "domains/payload/payload.cp", "plan_length": m}
        r1 = traj.robot("r1")
        assert r1.t_s[-1] == pytest.approx(m * 1.0)
        assert np.all(np.diff(r1.t_s) == pytest.approx(0.1))

    def test_grid_points_reproduced_through_forward_kinematics(self, traj, payload_scene: Scene) -> None:
        """The trajectory's joint values, put through FK, give back every state of the plan."""
        for k, name in enumerate(("r1", "r2")):
            r = traj.robot(name)
            at_steps = np.arange(0, traj.ticks, traj.points_per_step)
            x, y = forward(payload_scene.robot(name).arm, r.s[at_steps], np.radians(r.theta_deg[at_steps]))
            expected = np.array([pair[k] for pair in CLEAN_PAYLOAD_PLAN], dtype=float)
            np.testing.assert_allclose(np.column_stack([x, y]), expected, atol=1e-9)
            # every tick, not only the grid points, lies on the straight line between states
            xs, ys = forward(r.arm, r.s, np.radians(r.theta_deg))
            np.testing.assert_allclose(xs, r.x, atol=1e-9)
            np.testing.assert_allclose(ys, r.y, atol=1e-9)

    def test_motor_setpoints_reproduce_the_plan(self, traj) -> None:
        """Integer motor degrees back through the gear ratios and FK: within a degree's worth."""
        for r in traj.robots:
            x, y = r.xy_from_motor_deg(r.setpoints_deg)
            # 1/2 motor degree of s is 1/164 unit; 1/2 motor degree of theta moves the hand l*0.1 deg
            bound = 0.5 / 81.82 + r.arm.length * math.radians(0.5 / 5.0) + 1e-9
            assert np.max(np.hypot(x - r.x, y - r.y)) <= bound
            assert np.all(r.setpoints_deg[0] == 0)

    def test_two_motors_on_one_joint_move_together(self, traj) -> None:
        r = traj.robot("r1")
        assert r.ports == ("A", "B", "C")
        np.testing.assert_array_equal(r.setpoints_deg[:, 0], r.setpoints_deg[:, 1])
        expected = np.rint(81.82 * (r.s - r.s[0]))
        np.testing.assert_array_equal(r.setpoints_deg[:, 0], expected)
        np.testing.assert_array_equal(r.setpoints_deg[:, 2], np.rint(5.0 * (r.theta_deg - r.theta_deg[0])))

    def test_joint_path_is_continuous_on_one_branch(self, traj) -> None:
        """No jumps: per tick the joints move at most what the hand's motion allows."""
        for r in traj.robots:
            step_len = np.hypot(np.diff(r.x), np.diff(r.y))
            assert np.all(np.abs(np.diff(r.s)) <= 4 * step_len + 1e-9)
            assert np.all(np.abs(np.diff(np.radians(r.theta_deg))) <= 4 * step_len / r.arm.length + 1e-9)
            cos = np.cos(np.radians(r.theta_deg))
            assert np.all(cos * r.branch.branch >= -1e-9)  # never crosses to the other branch
            lo, hi = (math.degrees(t) for t in r.arm.theta_limits_rad)
            assert np.all((lo - 1e-9 <= r.theta_deg) & (r.theta_deg <= hi + 1e-9))
            assert np.all(r.setpoints_deg >= [m.min_deg for m in r.motors])
            assert np.all(r.setpoints_deg <= [m.max_deg for m in r.motors])

    def test_first_plan_is_refused(self, payload_scene: Scene) -> None:
        with pytest.raises(PlanViolationError) as err:
            build_trajectory(payload_scene, plan(*FIRST_PAYLOAD_PLAN))
        assert err.value.violation.kind == ViolationKind.PAYLOAD_LENGTH
        assert err.value.violation.step == 3
        traj = build_trajectory(payload_scene, plan(*FIRST_PAYLOAD_PLAN), check=False)
        assert traj.ticks == 10 * (len(FIRST_PAYLOAD_PLAN) - 1) + 1


class TestBranches:
    @pytest.fixture()
    def scene(self) -> Scene:
        return parse_scene(EXAMPLE_SCENE, "example.toml")

    def test_branch_is_chosen_to_keep_the_path_inside_the_limits(self, scene: Scene) -> None:
        """Near the left end of the rail only branch -1 keeps s >= -4 for r1."""
        states = plan(((-2, 1), (2, 4)), ((-1, 1), (1, 4)))
        traj = build_trajectory(scene, states, check=False, points_per_step=4)
        assert traj.robot("r1").branch.branch == -1
        assert traj.robot("r1").s.min() >= -4

    def test_least_motor_travel_wins_without_preference(self, scene: Scene) -> None:
        # moving across the reach limit direction: both branches feasible, travel differs
        states = plan(((2, 0), (2, 3)), ((4, 2), (4, 4)))
        traj = build_trajectory(scene, states, check=False, points_per_step=4)
        travel = {}
        for b in (1, -1):
            text = EXAMPLE_SCENE.replace("theta_limits_deg = [5, 175]",
                                         f"theta_limits_deg = [5, 175]\nbranch = {b}", 1)
            t = build_trajectory(parse_scene(text, "b.toml"), states, check=False, points_per_step=4)
            assert t.robot("r1").branch.branch == b
            travel[b] = np.abs(np.diff(t.robot("r1").setpoints_deg, axis=0)).sum()
        assert traj.robot("r1").branch.branch == min(travel, key=travel.get)
        assert travel[1] != travel[-1]

    def test_unreachable_point_names_robot_step_and_point(self, scene: Scene) -> None:
        states = plan(((1, 1), (1, 4)), ((1, 1), (1, 4)), ((1, 1), (1, 1.5)))
        with pytest.raises(UnreachableError) as err:
            build_trajectory(scene, states, check=False)
        msg = str(err.value)
        assert "robot r2" in msg and "from step 1 to 2" in msg and "(1, 2)" in msg

    def test_unreachable_start(self, scene: Scene) -> None:
        with pytest.raises(UnreachableError, match=r"robot r1 cannot reach \(1, 3\) at step 0"):
            build_trajectory(scene, plan(((1, 3), (1, 4)), ((1, 2), (1, 4))), check=False)

    def test_joint_limit_error(self, scene: Scene) -> None:
        with pytest.raises(JointLimitError, match=r"robot r1 cannot follow its path from step 0 to 1"):
            build_trajectory(scene, plan(((4, 1), (4, 4)), ((13, 1), (4, 4))), check=False)

    def test_bad_timing(self, scene: Scene) -> None:
        states = plan(((1, 1), (1, 4)))
        with pytest.raises(TrajectoryError, match="whole number of milliseconds"):
            build_trajectory(scene, states, points_per_step=3, step_time_s=1.0)
        with pytest.raises(TrajectoryError, match="points_per_step must be a positive integer"):
            build_trajectory(scene, states, points_per_step=0)
        with pytest.raises(TrajectoryError, match="step_time_s must be a positive number"):
            build_trajectory(scene, states, step_time_s=float("nan"))

    # In EXAMPLE_SCENE (rails at y = -1 and y = 5 along x, arms 3 long, s in [-4, 10]) branch
    # +1 holds r1 anywhere in x 0..8, y 0..2 and r2 anywhere in x 0..8, y 2..4 within the joint
    # limits, and these regions are convex: every plan inside them can be followed.
    _reachable = st.lists(st.tuples(st.integers(0, 8), st.integers(0, 2), st.integers(0, 8), st.integers(2, 4)),
                          min_size=1, max_size=5)

    @settings(max_examples=60)
    @given(_reachable, st.sampled_from([1, 2, 5, 8]))
    def test_any_reachable_plan_round_trips_through_fk(self, steps, pps) -> None:
        """Random plans inside the arms' reach (no checks) are never refused, and
        FK(joints) = the interpolated samples, through every state of the plan."""
        scene = parse_scene(EXAMPLE_SCENE, "e.toml")
        states = plan(*[((a, b), (c, d)) for a, b, c, d in steps])
        for state in states:
            for name, (x, y) in state.robots.items():
                assert BranchChoice(1) in choices_at(scene.robot(name).arm, x, y)
        traj = build_trajectory(scene, states, check=False, points_per_step=pps, step_time_s=0.04 * pps)
        for r in traj.robots:
            assert not np.isnan(r.s).any() and not np.isnan(r.theta_deg).any()
            x, y = r.forward(r.s, np.radians(r.theta_deg))
            np.testing.assert_allclose(np.column_stack([x, y]), r.path, atol=1e-9)
            at_steps = r.path[::pps]
            expected = [st.robots[r.name] for st in states]
            np.testing.assert_allclose(at_steps, expected, atol=1e-12)

    # Points no arm can hold: beyond reach (4 from the rail), or on the rail itself, where
    # theta would be 0 or 180 degrees, outside r1's [5, 175] and r2's [-175, -5].
    _BEYOND = {"r1": 3, "r2": 1}
    _ON_RAIL = {"r1": -1, "r2": 5}

    @settings(max_examples=60)
    @given(_reachable, st.data())
    def test_a_point_no_arm_can_hold_is_refused_naming_robot_and_step(self, steps, data) -> None:
        scene = parse_scene(EXAMPLE_SCENE, "e.toml")
        pairs = [[(a, b), (c, d)] for a, b, c, d in steps]
        k = data.draw(st.integers(0, len(pairs) - 1), label="step")
        j = data.draw(st.integers(0, 1), label="robot")
        robot = ("r1", "r2")[j]
        beyond = data.draw(st.booleans(), label="beyond reach")
        pairs[k][j] = (data.draw(st.integers(0, 8)), (self._BEYOND if beyond else self._ON_RAIL)[robot])
        error = UnreachableError if beyond else JointLimitError
        where = "at step 0" if k == 0 else f"from step {k - 1} to {k}"
        with pytest.raises(error, match=rf"robot {robot} cannot .*{where}"):
            build_trajectory(scene, plan(*[tuple(p) for p in pairs]), check=False, points_per_step=2,
                             step_time_s=0.2)
