"""What joins the planner to the world: robot tasks, refinement, execution on bricks.

* :class:`RobotTask` — a C+ domain plus a ``scene.toml`` (:mod:`cplus.robot.task`);
* :func:`refine` — the paper's Algorithm 1, learning position nogoods (:mod:`cplus.robot.refine`,
  :mod:`cplus.robot.nogoods`);
* :func:`export_plan` — picture, trajectory JSON/CSV (:mod:`cplus.robot.export`);
* :func:`execute_trajectory`, :func:`tracking_report` — a trajectory on NXT bricks, real or
  emulated (:mod:`cplus.robot.execution`).

This package may import :mod:`cplus`, :mod:`trajectory` and :mod:`nxt_link`; the language core
never imports it, and nothing here prints or exits: results carry statuses, and callbacks
report progress.
"""
from __future__ import annotations

from cplus.robot.export import check_outputs, export_plan
from cplus.robot.nogoods import Nogood
from cplus.robot.refine import (
    DEFAULT_MAX_HORIZON,
    Iteration,
    NogoodForm,
    Precheck,
    RefinementResult,
    RefineStatus,
    refine,
)
from cplus.robot.task import RobotTask, TaskError, scene_beside

__all__ = ["DEFAULT_MAX_HORIZON", "Iteration", "Nogood", "NogoodForm", "Precheck", "RefineStatus", "RefinementResult",
           "RobotTask", "TaskError", "check_outputs", "export_plan", "refine", "scene_beside"]
