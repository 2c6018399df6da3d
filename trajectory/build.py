"""From plan states to joint trajectories: interpolate, choose IK branches, convert to motors.

The paper executes a plan by interpolating intermediate points between the steps (so the arms
follow straight lines instead of jumping between set-points) and mapping every point to joint
values with inverse kinematics. `build_trajectory` does that:

1. optionally run the continuous checker and refuse a plan that fails it;
2. per robot, find the IK branches that can follow the *whole* piecewise-linear path within
   reach and joint limits (exactly, segment by segment, with `kinematics.segment_exit`); an
   impossible path is an `UnreachableError` or `JointLimitError` naming the robot, the step and
   the point, raised before anything is exported;
3. sample every motion at ``points_per_step`` ticks (``tick_ms = step_time_s * 1000 /
   points_per_step``), solve IK on the chosen branch (the scene's preferred one if it can
   follow the path, else the one needing the least motor travel), and check the result with
   forward kinematics;
4. convert joint values to integer motor degrees through each motor's gear ratio.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from ._format import fmt, fmt_point
from .checker import first_violation
from .errors import JointLimitError, PlanViolationError, TrajectoryError, UnreachableError
from .kinematics import Arm, BranchChoice, choices_at, forward, inverse, point_problem, surviving_choices
from .model import MotorChannel, RobotTrajectory, Trajectory, frozen_array
from .scene import Robot, Scene
from .states import StepState, validate_states

__all__ = ["build_trajectory", "check_timing", "interpolate_path", "path_branches"]

_log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]


def interpolate_path(
    waypoints: npt.ArrayLike, points_per_step: int
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Linear samples along a waypoint path: ``points_per_step`` per segment, plus the last point.

    Returns ``(samples, step)``: shape (m * points_per_step + 1, 2) and, per sample, the index
    of the motion it belongs to (the last sample gets ``m``).

    >>> pts, step = interpolate_path([(0, 0), (2, 0)], 4)
    >>> pts[:, 0].tolist(), step.tolist()
    ([0.0, 0.5, 1.0, 1.5, 2.0], [0, 0, 0, 0, 1])
    """
    wp = np.asarray(waypoints, dtype=float)
    m = len(wp) - 1
    k = np.arange(m * points_per_step + 1)
    step = np.minimum(k // points_per_step, max(m, 0))
    j = (k - step * points_per_step).astype(float)
    left = wp[step]
    right = wp[np.minimum(step + 1, m)]
    # multiply first, divide last: 0.3 rather than 0.30000000000000004
    samples = left + (right - left) * j[:, None] / points_per_step
    return samples, step.astype(np.int64)


def path_branches(robot: Robot, waypoints: Sequence[tuple[float, float]]) -> tuple[BranchChoice, ...]:
    """The IK branches that can follow the robot's whole path within reach and joint limits.

    Raises
    ------
    UnreachableError, JointLimitError
        Naming the robot, the step and the point where every branch fails.
    """
    arm = robot.arm
    start = waypoints[0]
    alive = choices_at(arm, start[0], start[1])
    if not alive:
        problem = point_problem(arm, start[0], start[1], 1)
        assert problem is not None
        if problem[0]:
            raise UnreachableError(f"robot {robot.name} cannot reach {fmt_point(start)} at step 0: "
                                   f"{problem[1]}")
        other = point_problem(arm, start[0], start[1], -1)
        raise JointLimitError(f"robot {robot.name} cannot hold {fmt_point(start)} at step 0 within "
                              f"its joint limits: branch +1: {problem[1]}; branch -1: "
                              f"{other[1] if other else 'ok'}")
    for i in range(len(waypoints) - 1):
        p, q = waypoints[i], waypoints[i + 1]
        survivors, dead = surviving_choices(arm, alive, p, q)
        if survivors:
            alive = survivors
            continue
        worst = max(dead, key=lambda cd: cd[1].u)[1]
        detail = "; ".join(f"{c}: {ex.reason}, from {fmt_point(ex.point)}" for c, ex in dead)
        head = (f"robot {robot.name} cannot follow its path from step {i} to {i + 1} "
                f"({fmt_point(p)} -> {fmt_point(q)}): ")
        if any(ex.out_of_reach for _, ex in dead):
            raise UnreachableError(head + f"the point {fmt_point(worst.point)} is out of reach; " + detail)
        raise JointLimitError(head + f"at {fmt_point(worst.point)} no IK branch stays within the "
                              "joint limits; " + detail)
    return alive


def _joint_values(arm: Arm, samples: FloatArray, choice: BranchChoice) -> tuple[FloatArray, FloatArray]:
    s, theta = inverse(arm, samples[:, 0], samples[:, 1], choice)
    # samples lie on segments checked exactly; clip rounding noise at a limit
    s = np.clip(s, *arm.s_limits)
    theta = np.clip(theta, *arm.theta_limits_rad)
    return s, theta


def _motor_channels(robot: Robot, s0: float, theta0_deg: float) -> tuple[MotorChannel, ...]:
    out = []
    for motor in robot.motors:
        if motor.joint == "s":
            zero, lo, hi = s0, *robot.arm.s_limits
        else:
            zero = theta0_deg
            lo, hi = (math.degrees(t) for t in robot.arm.theta_limits_rad)
        ends = sorted(motor.offset_deg + motor.deg_per_unit * (v - zero) for v in (lo, hi))
        out.append(MotorChannel(motor.port, motor.joint, motor.deg_per_unit, motor.offset_deg, zero,
                                math.ceil(ends[0] - 1e-9), math.floor(ends[1] + 1e-9)))
    return tuple(out)


def _setpoints(
    channels: Sequence[MotorChannel], s: FloatArray, theta_deg: FloatArray
) -> npt.NDArray[np.int64]:
    cols = []
    for ch in channels:
        raw = ch.motor_deg(s if ch.joint == "s" else theta_deg)
        cols.append(np.clip(np.rint(raw), ch.min_deg, ch.max_deg))
    return np.column_stack(cols).astype(np.int64)


def _robot_trajectory(robot: Robot, samples: FloatArray, step: npt.NDArray[np.int64], t_s: FloatArray,
                      waypoints: Sequence[tuple[float, float]]) -> RobotTrajectory:
    candidates = path_branches(robot, waypoints)
    solved = []
    for choice in candidates:
        s, theta = _joint_values(robot.arm, samples, choice)
        channels = _motor_channels(robot, float(s[0]), math.degrees(float(theta[0])))
        setpoints = _setpoints(channels, s, np.degrees(theta))
        travel = float(np.abs(np.diff(setpoints, axis=0)).sum())
        preferred = robot.branch is not None and choice.branch == robot.branch
        solved.append((not preferred, travel, choice.branch != 1, choice, s, theta, channels, setpoints))
    if robot.branch is not None and not any(not entry[0] for entry in solved):
        _log.info("robot %s: preferred IK branch %+d cannot follow the path; using the other",
                  robot.name, robot.branch)
    _, _, _, choice, s, theta, channels, setpoints = min(solved, key=lambda e: e[:3])
    x, y = forward(robot.arm, s, theta)
    error = float(np.max(np.hypot(x - samples[:, 0], y - samples[:, 1])))
    if error > 1e-6 * robot.arm.scale:
        raise TrajectoryError(f"internal error: forward kinematics of robot {robot.name} misses its "
                              f"samples by {error:.3g} grid units")
    return RobotTrajectory(
        name=robot.name, arm=robot.arm, branch=choice, motors=channels,
        t_s=frozen_array(t_s), step=frozen_array(step, np.int64),
        x=frozen_array(samples[:, 0]), y=frozen_array(samples[:, 1]),
        s=frozen_array(s), theta_deg=frozen_array(np.degrees(theta)),
        setpoints_deg=frozen_array(setpoints, np.int64),
    )


def check_timing(points_per_step: int, step_time_s: float) -> int:
    """The tick in whole milliseconds, or a `TrajectoryError` saying why these cannot be used.

    >>> check_timing(10, 1.0), check_timing(4, 0.5)
    (100, 125)
    """
    if isinstance(points_per_step, bool) or not isinstance(points_per_step, int) or points_per_step < 1:
        raise TrajectoryError(f"points_per_step must be a positive integer, not {points_per_step!r}")
    if not (isinstance(step_time_s, (int, float)) and math.isfinite(step_time_s) and step_time_s > 0):
        raise TrajectoryError(f"step_time_s must be a positive number of seconds, not {step_time_s!r}")
    tick = step_time_s * 1000.0 / points_per_step
    tick_ms = round(tick)
    if tick_ms < 1 or not math.isclose(tick, tick_ms, rel_tol=0.0, abs_tol=1e-6):
        raise TrajectoryError(f"step_time_s * 1000 / points_per_step = {fmt(tick)} ms; it must be a "
                              "whole number of milliseconds, at least 1")
    return tick_ms


def build_trajectory(
    scene: Scene,
    states: Sequence[StepState],
    *,
    points_per_step: int = 10,
    step_time_s: float = 1.0,
    check: bool = True,
    source: Mapping[str, Any] | None = None,
) -> Trajectory:
    """Turn plan states into per-robot joint and motor trajectories.

    Parameters
    ----------
    scene
        The scene the plan was made for.
    states
        One `StepState` per step 0..m.
    points_per_step
        Samples per motion (the tick count of one step).
    step_time_s
        Duration of one step; ``step_time_s * 1000 / points_per_step`` must be a whole
        number of milliseconds (the tick).
    check
        Run `first_violation` first and raise `PlanViolationError` if the plan fails it.
    source
        Extra provenance for the file (``{"domain": "domains/payload/payload.cp"}``);
        ``plan_length`` is filled in.

    Raises
    ------
    PlanStateError, PlanViolationError, UnreachableError, JointLimitError, TrajectoryError

    >>> from trajectory.scene import parse_scene, EXAMPLE_SCENE
    >>> scene = parse_scene(EXAMPLE_SCENE, "example.toml")
    >>> at = lambda p1, p2: StepState({"r1": p1, "r2": p2}, {"pl1": p1, "pl2": p2},
    ...                               {"pl1": "r1", "pl2": "r2"})
    >>> traj = build_trajectory(scene, [at((4, 1), (4, 4)), at((5, 1), (5, 4))], points_per_step=4)
    >>> traj.tick_ms, traj.ticks, traj.robot("r1").x.tolist()
    (250, 5, [4.0, 4.25, 4.5, 4.75, 5.0])
    """
    tick_ms = check_timing(points_per_step, step_time_s)
    validate_states(scene.robot_names, scene.end_names, states)
    if check:
        violation = first_violation(scene, states)
        if violation is not None:
            raise PlanViolationError(violation)
    m = len(states) - 1
    robots = []
    for robot in scene.robots:
        waypoints = [st.robots[robot.name] for st in states]
        samples, step = interpolate_path(waypoints, points_per_step)
        t_s = np.arange(len(samples)) * tick_ms / 1000.0
        robots.append(_robot_trajectory(robot, samples, step, t_s, waypoints))
    info: dict[str, Any] = dict(source or {})
    info["plan_length"] = m
    return Trajectory(tick_ms=tick_ms, step_time_s=float(step_time_s), points_per_step=points_per_step,
                      plan_length=m, robots=tuple(robots), source=info)
