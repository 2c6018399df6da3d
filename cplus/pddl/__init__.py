"""PDDL in: a domain and problem read by unified-planning's PDDL reader, translated to C+
(:mod:`cplus.pddl.translate`) and planned for by cplus (:mod:`cplus.pddl.solve`).

unified-planning is the optional extra ``up``; it is imported only when a PDDL file is read.
"""
from __future__ import annotations

from cplus.pddl.read import PddlError, read_problem, require_up
from cplus.pddl.solve import FORMAT, PddlPlan, PlanInvalidError, ipc_text, plan_json, plan_problem
from cplus.pddl.translate import Translation, check_kind, translate

__all__ = ["PddlError", "PddlPlan", "PlanInvalidError", "Translation", "FORMAT", "check_kind", "ipc_text",
           "plan_json", "plan_problem", "read_problem", "require_up", "translate"]
