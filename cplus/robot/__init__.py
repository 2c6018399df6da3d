"""What joins the planner to the world, one package per concern:

* :mod:`cplus.robot.offline` — the robot task: a C+ domain plus a ``scene.toml``, refined until
  collision-free (the paper's Algorithm 1), exported as pictures and trajectories;
* :mod:`cplus.robot.execution` — a trajectory on NXT bricks, real or emulated, and the
  tracking report;
* :mod:`cplus.robot.online` — the online loop: act, sense, decide again;
* :mod:`cplus.robot.serving` — reactive goals from clients (script, socket, ROS actionlib),
  built on the online loop.

Arrows between them point one way: serving → online → {offline, execution}, each through the
other's face (its ``__init__``); ``tests/test_layering.py`` enforces it. All of them may import
:mod:`cplus`, :mod:`trajectory` and :mod:`nxt_link`; the language core never imports them, and
nothing here prints or exits: results carry statuses, and callbacks report progress.

This face keeps the offline task's names, which most callers want (``from cplus.robot import
RobotTask, refine``).
"""
from __future__ import annotations

from cplus.robot.offline import (
    DEFAULT_MAX_HORIZON,
    Iteration,
    Nogood,
    NogoodForm,
    Precheck,
    RefinementResult,
    RefineStatus,
    RobotTask,
    TaskError,
    check_outputs,
    export_plan,
    refine,
    refine_parallel,
    scene_beside,
)

__all__ = ["DEFAULT_MAX_HORIZON", "Iteration", "Nogood", "NogoodForm", "Precheck", "RefineStatus", "RefinementResult",
           "RobotTask", "TaskError", "check_outputs", "export_plan", "refine", "refine_parallel",
           "scene_beside"]
