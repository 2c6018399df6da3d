"""The trajectory value: per robot and per tick, where the hand is, the joints, the motors.

A `Trajectory` is what `build_trajectory` produces and `load_trajectory` reads back. It is
frozen; its arrays are read-only NumPy arrays. Besides the data it carries what the execution
side needs to go back from logged motor angles to positions: `MotorChannel` knows its gear
ratio and the joint value at which it reads ``offset_deg``, and `RobotTrajectory` knows its
arm, so ``robot.xy_from_motor_deg(rows)`` turns an encoder log into an executed path.

Motor convention (`cplus.trajectory/1`): encoders are reset at the start configuration, so

    motor_deg = offset_deg + deg_per_unit * (joint - zero_joint)

where ``joint`` is ``s`` in grid units or ``theta`` in degrees, and ``zero_joint`` is that
joint's value at tick 0. Setpoints are rounded to whole degrees.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np
import numpy.typing as npt

from .kinematics import Arm, BranchChoice, forward

__all__ = ["TRAJECTORY_FORMAT", "MotorChannel", "RobotTrajectory", "Trajectory"]

TRAJECTORY_FORMAT = "cplus.trajectory/1"

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def frozen_array(values: npt.ArrayLike, dtype: type = float) -> npt.NDArray[Any]:
    """A read-only copy, so a frozen dataclass holding it stays immutable."""
    arr: npt.NDArray[Any] = np.array(values, dtype=dtype)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, slots=True)
class MotorChannel:
    """One motor of one robot and how its degrees relate to its joint.

    >>> arm_motor = MotorChannel("C", "theta", deg_per_unit=5.0, offset_deg=0.0, zero_joint=20.0,
    ...                          min_deg=-75, max_deg=775)
    >>> float(arm_motor.motor_deg(30.0)), float(arm_motor.joint_value(50.0))   # 10 deg = 50 motor deg
    (50.0, 30.0)
    """

    port: str
    joint: str
    deg_per_unit: float
    offset_deg: float
    zero_joint: float
    min_deg: int
    max_deg: int

    def motor_deg(self, joint_value: npt.ArrayLike) -> FloatArray:
        """Unrounded motor degrees for joint values (``s`` grid units, ``theta`` degrees)."""
        return self.offset_deg + self.deg_per_unit * (np.asarray(joint_value, dtype=float) - self.zero_joint)

    def joint_value(self, motor_deg: npt.ArrayLike) -> FloatArray:
        """Joint values (``s`` grid units, ``theta`` degrees) for motor degrees."""
        return self.zero_joint + (np.asarray(motor_deg, dtype=float) - self.offset_deg) / self.deg_per_unit


@dataclass(frozen=True, slots=True, eq=False)
class RobotTrajectory:
    """One robot's samples, one per tick, and its motor setpoints.

    ``setpoints_deg[k, j]`` is the integer angle of ``motors[j]`` at tick ``k``.
    """

    name: str
    arm: Arm
    branch: BranchChoice
    motors: tuple[MotorChannel, ...]
    t_s: FloatArray
    step: IntArray
    x: FloatArray
    y: FloatArray
    s: FloatArray
    theta_deg: FloatArray
    setpoints_deg: IntArray

    @property
    def ports(self) -> tuple[str, ...]:
        return tuple(m.port for m in self.motors)

    @property
    def path(self) -> FloatArray:
        """The planned end-effector path, shape (ticks, 2)."""
        return np.column_stack([self.x, self.y])

    def joints_from_motor_deg(self, motor_deg: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """``(s, theta_rad)`` from motor angles ordered like ``motors`` (shape (..., motors)).

        When several motors drive one joint (two wheels moving the carriage), their joint
        values are averaged.
        """
        rows = np.asarray(motor_deg, dtype=float)
        if rows.shape[-1] != len(self.motors):
            raise ValueError(f"robot {self.name} has {len(self.motors)} motors "
                             f"({', '.join(self.ports)}), got rows of {rows.shape[-1]} angles")
        values: dict[str, list[FloatArray]] = {"s": [], "theta": []}
        for j, motor in enumerate(self.motors):
            values[motor.joint].append(motor.joint_value(rows[..., j]))
        s = np.mean(values["s"], axis=0)
        theta_rad = np.radians(np.mean(values["theta"], axis=0))
        return s, theta_rad

    def forward(self, s: npt.ArrayLike, theta_rad: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """End-effector ``(x, y)`` for joint values (forward kinematics of this robot's arm)."""
        return forward(self.arm, s, theta_rad)

    def xy_from_motor_deg(self, motor_deg: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """End-effector ``(x, y)`` for motor angles: an encoder log becomes a path."""
        return self.forward(*self.joints_from_motor_deg(motor_deg))


@dataclass(frozen=True, slots=True, eq=False)
class Trajectory:
    """All robots' samples on a common clock: ``ticks`` samples ``tick_ms`` apart."""

    tick_ms: int
    step_time_s: float
    points_per_step: int
    plan_length: int
    robots: tuple[RobotTrajectory, ...]
    source: Mapping[str, Any]

    def __post_init__(self) -> None:
        object.__setattr__(self, "source", MappingProxyType(dict(self.source)))
        if not self.robots:
            raise ValueError("a trajectory needs at least one robot")
        ticks = {len(r.t_s) for r in self.robots}
        if len(ticks) != 1:
            raise ValueError("all robots of a trajectory must have the same number of ticks")
        if not math.isclose(self.tick_ms * self.points_per_step, self.step_time_s * 1000.0):
            raise ValueError("tick_ms * points_per_step must equal step_time_s in milliseconds")

    @property
    def format(self) -> str:
        return TRAJECTORY_FORMAT

    @property
    def ticks(self) -> int:
        return len(self.robots[0].t_s)

    def robot(self, name: str) -> RobotTrajectory:
        """The robot called ``name``; `KeyError` if there is none."""
        for robot in self.robots:
            if robot.name == name:
                return robot
        raise KeyError(name)

    def planned_paths(self) -> dict[str, FloatArray]:
        """Each robot's planned end-effector path, shape (ticks, 2), for `plot_execution`."""
        return {r.name: r.path for r in self.robots}
