"""A refined plan's products: its picture, its joint trajectory as JSON and CSV."""
from __future__ import annotations

import os
from collections.abc import Callable

from cplus.robot.task import RobotTask, TaskError

__all__ = ["export_plan"]


def export_plan(task: RobotTask, states: list, violation, *, domain_path: str, plot: str | None = None,
                trajectory_json: str | None = None, csv: str | None = None, points_per_step: int = 10,
                step_time: float = 1.0, on_write: Callable[[str], None] | None = None) -> list[str]:
    """Write what was asked for and return the paths written, in order.

    A plan with a violation may be drawn (the violation is marked) but never exported as a
    trajectory: a trajectory is something a robot may execute.

    Raises:
        TaskError: the trajectory cannot be built (an unreachable point), the plan is unsafe,
            or a file cannot be written.
    """
    import trajectory
    written: list[str] = []

    def wrote(path: str) -> None:
        written.append(path)
        if on_write:
            on_write(path)

    for out in (plot, trajectory_json, csv):
        if out:
            os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    try:
        if plot:
            trajectory.plot_plan(task.scene, states, violation, path=plot,  # type: ignore[arg-type]
                                 title=f"{os.path.basename(domain_path)}: plan of length {len(states) - 1}")
            wrote(plot)
        if trajectory_json or csv:
            if violation is not None:
                raise TaskError("the plan is not collision-free; refusing to export its trajectory")
            traj = trajectory.build_trajectory(task.scene, states, points_per_step=points_per_step,  # type: ignore[arg-type]
                                               step_time_s=step_time, source={"domain": domain_path})
            if trajectory_json:
                trajectory.save_json(traj, trajectory_json)
                wrote(trajectory_json)
            if csv:
                trajectory.save_csv(traj, csv)
                wrote(csv)
    except trajectory.TrajectoryError as exc:
        raise TaskError.from_trajectory(exc) from None
    except OSError as exc:
        raise TaskError(f"cannot write output: {exc.strerror or exc}") from None
    return written
