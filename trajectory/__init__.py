"""Scene geometry, continuous collision checks, kinematics, trajectory export and plots.

The pipeline from a plan to motion, as the planner's glue calls it::

    scene = load_scene("domains/payload/scene.toml")      # validated, located errors
    scene.collision(x1, y1, x2, y2)                        # the domain's external
    violation = first_violation(scene, states)             # Algorithm 1's check
    traj = build_trajectory(scene, states, points_per_step=10, step_time_s=1.0)
    save_json(traj, "out/trajectory.json"); save_csv(traj, "out/trajectory.csv")
    plot_plan(scene, states, violation, path="out/plan.png")
    animate_run(scene, traj, "out/plan.gif")                # GIF, or MP4 with ffmpeg

`trajectory` never imports `cplus` or `nxt_link`: plans arrive as `StepState` lists and leave
as `cplus.trajectory/1` files. See ``docs/trajectory.md``.
"""

from typing import TYPE_CHECKING, Any

from .build import build_trajectory, check_timing, interpolate_path
from .checker import Cause, Violation, ViolationKind, all_violations, cause_of, check_motion, first_violation
from .errors import (
    JointLimitError,
    Location,
    PlanStateError,
    PlanViolationError,
    SceneError,
    TrajectoryError,
    TrajectoryFormatError,
    UnreachableError,
)
from .export import load_trajectory, save_csv, save_json, to_csv_text, to_json_text
from .generalize import widen
from .kinematics import Arm, BranchChoice, JointState, forward, ik_solutions, inverse
from .model import TRAJECTORY_FORMAT, MotorChannel, RobotTrajectory, Trajectory
from .precheck import BadMotion, bad_single_body_motions, failing_length_pairs
from .scene import SCENE_FORMAT, Scene, check_reachable, load_scene, parse_scene
from .states import StepState
from .timeline import BrickTimeline, CycleFrame, RunTimeline

if TYPE_CHECKING:
    from .animate import animate_cycles, animate_run, animation_problem, cycles_figure
    from .plots import execution_figure, motor_roles, plan_figure, plan_title, plot_execution, plot_plan

_PLOTS = ("plot_plan", "plot_execution", "plan_figure", "execution_figure", "plan_title", "motor_roles")
_ANIMATIONS = ("animate_run", "animate_cycles", "animation_problem", "cycles_figure")


def __getattr__(name: str) -> Any:
    """Import the plotting and animation functions (and matplotlib) only when first used."""
    if name in _PLOTS:
        from . import plots

        return getattr(plots, name)
    if name in _ANIMATIONS:
        from . import animate

        return getattr(animate, name)
    raise AttributeError(f"module 'trajectory' has no attribute {name!r}")


__all__ = [
    "Arm",
    "BadMotion",
    "BrickTimeline",
    "CycleFrame",
    "RunTimeline",
    "animate_cycles",
    "animate_run",
    "animation_problem",
    "cycles_figure",
    "execution_figure",
    "motor_roles",
    "plan_figure",
    "plan_title",
    "BranchChoice",
    "Cause",
    "JointLimitError",
    "JointState",
    "Location",
    "MotorChannel",
    "PlanStateError",
    "PlanViolationError",
    "RobotTrajectory",
    "SCENE_FORMAT",
    "Scene",
    "SceneError",
    "StepState",
    "TRAJECTORY_FORMAT",
    "Trajectory",
    "TrajectoryError",
    "TrajectoryFormatError",
    "UnreachableError",
    "Violation",
    "ViolationKind",
    "all_violations",
    "bad_single_body_motions",
    "build_trajectory",
    "cause_of",
    "failing_length_pairs",
    "widen",
    "check_motion",
    "check_timing",
    "check_reachable",
    "first_violation",
    "forward",
    "ik_solutions",
    "interpolate_path",
    "inverse",
    "load_scene",
    "load_trajectory",
    "parse_scene",
    "plot_execution",
    "plot_plan",
    "save_csv",
    "save_json",
    "to_csv_text",
    "to_json_text",
]
