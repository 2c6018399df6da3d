"""A refined plan's products: its picture, its joint trajectory as JSON and CSV.

:func:`check_outputs` runs before any planning, so that a path that cannot be written or a
timing that cannot be sampled is refused in seconds, not after the refinement.
"""
from __future__ import annotations

import os
from collections.abc import Callable

from cplus.robot.offline.task import RobotTask, TaskError

__all__ = ["check_outputs", "export_plan"]


def check_outputs(*, plot: str | None = None, trajectory_json: str | None = None, csv: str | None = None,
                  points_per_step: int = 10, step_time: float = 1.0) -> None:
    """Refuse, before anything is planned, outputs that cannot be written and a sampling that
    cannot be used (``--points-per-step`` and ``--step-time`` must give a whole tick of at
    least one millisecond).

    Raises:
        TaskError: naming the option and why.
    """
    import trajectory
    outputs = [(opt, path) for opt, path in (("--plot", plot), ("--trajectory", trajectory_json), ("--csv", csv))
               if path]
    try:
        trajectory.check_timing(points_per_step, step_time)
    except trajectory.TrajectoryError as exc:
        raise TaskError(f"--step-time {step_time:g} with --points-per-step {points_per_step}: {exc.message}") from None
    if plot and os.path.splitext(plot)[1].lower() not in (".png", ".svg"):
        raise TaskError(f"--plot {plot}: the picture must be a .png or .svg file")
    seen: dict[str, str] = {}
    for opt, path in outputs:
        real = os.path.realpath(path)
        if real in seen:
            raise TaskError(f"{seen[real]} and {opt} name the same file '{path}'")
        seen[real] = opt
        why = _unwritable(path)
        if why:
            raise TaskError(f"{opt} {path}: cannot write: {why}")


def _unwritable(path: str) -> str | None:
    """Why ``path`` cannot be written (created with its missing directories), or ``None``."""
    p = os.path.abspath(path)
    if os.path.isdir(p):
        return "it is a directory"
    if os.path.exists(p):
        return None if os.access(p, os.W_OK) else "permission denied"
    parent = os.path.dirname(p)
    while not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent):
        return f"'{parent}' is not a directory"
    if not os.access(parent, os.W_OK | os.X_OK):
        return f"cannot create files in '{parent}': permission denied"
    return None


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

    try:
        for out in (plot, trajectory_json, csv):
            if out:
                os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
        if plot:
            trajectory.plot_plan(task.scene, states, violation, path=plot,  # type: ignore[arg-type]
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
