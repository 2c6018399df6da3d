"""The offline robot task: a C+ domain beside a ``scene.toml``, planned and refined until its
plan is collision-free (the paper's Algorithm 1), and exported as pictures and trajectories.

Nothing here runs anything on a brick or waits on the world: this is what ``cplus plan`` does
with a robot task. The online loop uses it (re-planning the arms mid-run); it uses neither the
online loop nor serving.

* :class:`RobotTask` — a domain plus its scene (:mod:`.task`);
* :func:`refine` — plan, check between steps, learn nogoods, plan again (:mod:`.refine`), with
  the nogoods of :mod:`.nogoods`;
* :func:`export_plan`, :func:`check_outputs` — picture and trajectory files (:mod:`.export`);
* :func:`refine_parallel` — the same refinement with horizons on worker processes, nogoods
  shared between them (:mod:`.parallel`; imported when first called, so that a robot task
  without ``--jobs`` does not load the parallel machinery).
"""
from __future__ import annotations

from cplus.robot.offline.export import check_outputs, export_plan
from cplus.robot.offline.nogoods import Nogood, NogoodStore, position_nogood
from cplus.robot.offline.refine import (
    DEFAULT_MAX_HORIZON,
    REFINE_SOLVER,
    Iteration,
    NogoodForm,
    Precheck,
    RefinementResult,
    RefineStatus,
    refine,
)
from cplus.robot.offline.task import RobotTask, TaskError, scene_beside


def refine_parallel(*args, **kwargs):
    """:func:`cplus.robot.offline.parallel.refine_parallel` (see there)."""
    from cplus.robot.offline.parallel import refine_parallel as run
    return run(*args, **kwargs)


__all__ = ["DEFAULT_MAX_HORIZON", "REFINE_SOLVER", "Iteration", "Nogood", "NogoodForm", "NogoodStore", "Precheck",
           "RefineStatus", "RefinementResult", "RobotTask", "TaskError", "check_outputs", "export_plan",
           "position_nogood", "refine", "refine_parallel", "scene_beside"]
