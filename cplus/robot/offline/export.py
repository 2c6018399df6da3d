"""A refined plan's products: its picture, its joint trajectory as JSON and CSV.

:func:`check_outputs` runs before any planning, so that a timing that cannot be sampled is
refused in seconds, not after the refinement.  Files are written by :mod:`cplus.files`'s rule:
a regular file replaced atomically, a device or a FIFO written through.
"""
from __future__ import annotations

import os
from collections.abc import Callable

from cplus.files import output_path, write_output
from cplus.robot.offline.task import RobotTask, TaskError

__all__ = ["check_outputs", "export_plan"]


def check_outputs(*, plot: str | None = None, trajectory_json: str | None = None, csv: str | None = None,
                  points_per_step: int = 10, step_time: float = 1.0) -> None:
    """Refuse, before anything is planned, a sampling that cannot be used (``--points-per-step``
    and ``--step-time`` must give a whole tick of at least one millisecond) and a picture that
    is neither PNG nor SVG.  Whether the paths can be written is the command's check, with its
    other inputs and outputs (:mod:`cplus.cli.paths`).

    Raises:
        TaskError: naming the option and why.
    """
    import trajectory
    try:
        trajectory.check_timing(points_per_step, step_time)
    except trajectory.TrajectoryError as exc:
        raise TaskError(f"--step-time {step_time:g} with --points-per-step {points_per_step}: {exc.message}") from None
    if plot and os.path.splitext(plot)[1].lower() not in (".png", ".svg"):
        raise TaskError(f"--plot {plot}: the picture must be a .png or .svg file")
    del trajectory_json, csv


def export_plan(task: RobotTask, states: list, violation, *, domain_path: str, plot: str | None = None,
                trajectory_json: str | None = None, csv: str | None = None, points_per_step: int = 10,
                step_time: float = 1.0, on_write: Callable[[str], None] | None = None) -> list[str]:
    """Write what was asked for and return the paths written, in order.

    A plan with a violation may be drawn (the violation is marked) but never exported as a
    trajectory: a trajectory is something a robot may execute.

    Raises:
        TaskError: the trajectory cannot be built (an unreachable point), the plan is unsafe
            (after its picture is written), or a file cannot be written.
    """
    import trajectory
    written: list[str] = []

    def wrote(path: str) -> None:
        written.append(path)
        if on_write:
            on_write(path)

    writing = None
    try:
        if plot:
            writing = plot
            with output_path(plot) as tmp:
                trajectory.plot_plan(task.scene, states, violation, path=tmp,  # type: ignore[arg-type]
                                     title=trajectory.plan_title(task.scene, len(states) - 1,  # type: ignore[arg-type]
                                                                 os.path.basename(domain_path)))
            wrote(plot)
        if trajectory_json or csv:
            if violation is not None:
                raise TaskError("the plan is not collision-free; refusing to export its trajectory")
            traj = trajectory.build_trajectory(task.scene, states, points_per_step=points_per_step,  # type: ignore[arg-type]
                                               step_time_s=step_time,
                                               source=_source(task, domain_path, trajectory_json or csv))
            if trajectory_json:
                writing = trajectory_json
                write_output(trajectory_json, trajectory.to_json_text(traj))
                wrote(trajectory_json)
            if csv:
                writing = csv
                write_output(csv, trajectory.to_csv_text(traj))
                wrote(csv)
    except trajectory.TrajectoryError as exc:
        raise TaskError.from_trajectory(exc) from None
    except OSError as exc:
        raise TaskError(f"cannot write {writing}: {exc.strerror or exc}") from None
    return written


def _source(task: RobotTask, domain_path: str, out: str | None) -> dict[str, str]:
    """The trajectory's ``source``: its domain and scene, relative to the trajectory file's
    folder (:func:`trajectory.export.file_reference`), so that ``cplus execute`` finds the scene
    from any working directory."""
    from trajectory.export import file_reference
    source = {"domain": domain_path}
    files = {"domain": domain_path, "scene": task.scene.file}  # type: ignore[attr-defined]
    for key, path in files.items():
        if out is not None and os.path.isfile(path):
            source[key] = file_reference(path, out)
    return source
