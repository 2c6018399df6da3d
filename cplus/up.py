"""cplus as a unified-planning engine: ``OneshotPlanner(name="cplus")``.

Register it once (the optional extra ``up`` installs unified-planning)::

    from unified_planning.shortcuts import get_environment
    get_environment().factory.add_engine("cplus", "cplus.up", "CPlusEngine")

The engine declares exactly the problem kind the C+ translation handles
(:data:`cplus.pddl.translate.SUPPORTED_FEATURES`, without static numeric functions in costs),
so the factory never hands it another.  Options: ``sequential`` (one action a step: with unit
costs the plan is then proved shortest, ``SOLVED_OPTIMALLY``), ``max_horizon`` (the last plan
length tried), ``minimize`` (with action costs: the cheapest plan of the shortest length, or of
any length up to the horizon with ``over_lengths``), ``solver``.

Statuses: ``SOLVED_SATISFICING``; ``SOLVED_OPTIMALLY`` only when proved (above);
``UNSOLVABLE_PROVEN`` when no plan exists up to 2^n - 1 steps, n the ground atoms the actions
change (no plan can be longer without repeating a state: :data:`cplus.pddl.solve.PROOF_ATOMS`
bounds n); ``UNSOLVABLE_INCOMPLETELY`` when only ``max_horizon`` was reached; ``TIMEOUT`` when
``timeout`` seconds passed (the search runs in a child process, ended then).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import IO, Any

import unified_planning as up
from unified_planning.engines import (
    Engine,
    OptimalityGuarantee,
    PlanGenerationResult,
    PlanGenerationResultStatus,
)
from unified_planning.engines.mixins import OneshotPlannerMixin
from unified_planning.model import ProblemKind

__all__ = ["CPlusEngine", "register"]

_KIND = ["ACTION_BASED", "FLAT_TYPING", "HIERARCHICAL_TYPING", "NEGATIVE_CONDITIONS", "DISJUNCTIVE_CONDITIONS",
         "EQUALITIES", "EXISTENTIAL_CONDITIONS", "UNIVERSAL_CONDITIONS", "CONDITIONAL_EFFECTS", "FORALL_EFFECTS",
         "ACTIONS_COST", "PLAN_LENGTH", "INT_NUMBERS_IN_ACTIONS_COST"]


def register(name: str = "cplus") -> None:
    """Add the engine to unified-planning's factory under ``name`` (once)."""
    factory = up.environment.get_environment().factory
    if name not in factory.engines:
        factory.add_engine(name, "cplus.up", "CPlusEngine")


class CPlusEngine(Engine, OneshotPlannerMixin):
    """The cplus SAT planner (a C+ translation, solved with increasing plan lengths)."""

    def __init__(self, sequential: bool = False, max_horizon: int | None = None, minimize: bool = False,
                 over_lengths: bool = False, solver: str | None = None) -> None:
        Engine.__init__(self)
        OneshotPlannerMixin.__init__(self)
        self.sequential = sequential
        self.max_horizon = max_horizon
        self.minimize = minimize
        self.over_lengths = over_lengths
        self.solver = solver

    @property
    def name(self) -> str:
        return "cplus"

    @staticmethod
    def supported_kind() -> ProblemKind:
        return ProblemKind(_KIND, version=2)

    @staticmethod
    def supports(problem_kind: ProblemKind) -> bool:
        return problem_kind <= CPlusEngine.supported_kind()

    @staticmethod
    def satisfies(optimality_guarantee: OptimalityGuarantee) -> bool:
        return optimality_guarantee == OptimalityGuarantee.SATISFICING

    def _solve(self, problem: Any, heuristic: Callable | None = None, timeout: float | None = None,
               output_stream: IO[str] | None = None) -> PlanGenerationResult:
        from cplus.pddl import check_kind
        check_kind(problem)
        if timeout is None:
            plan = self._plan(problem)
        else:
            found = _in_child(self, problem, timeout)
            if found is None:
                return PlanGenerationResult(PlanGenerationResultStatus.TIMEOUT, None, self.name)
            plan = found
        if plan.status == "found":
            optimal = plan.optimal == "length" or (plan.optimal == "cost" and self.minimize)
            status = (PlanGenerationResultStatus.SOLVED_OPTIMALLY if optimal
                      else PlanGenerationResultStatus.SOLVED_SATISFICING)
            return PlanGenerationResult(status, plan.plan, self.name)
        status = (PlanGenerationResultStatus.UNSOLVABLE_PROVEN if plan.proved
                  else PlanGenerationResultStatus.UNSOLVABLE_INCOMPLETELY)
        return PlanGenerationResult(status, None, self.name)

    def _plan(self, problem: Any) -> Any:
        from cplus.pddl import plan_problem
        return plan_problem(problem, sequential=self.sequential, minimize=self.minimize,
                            over_lengths=self.over_lengths, max_horizon=self.max_horizon, solver=self.solver,
                            name=f"<C+ of {problem.name}>")


def _in_child(engine: CPlusEngine, problem: Any, timeout: float) -> Any:
    """Plan in a forked child for at most ``timeout`` seconds (None: it ran out); the plan comes
    back by names and is rebuilt on this side."""
    import multiprocessing as mp
    ctx = mp.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)

    def work() -> None:
        try:
            plan = engine._plan(problem)
            send.send(("ok", plan.status, plan.proved, plan.optimal, plan.cost,
                       [[(a.action.name, [p.object().name for p in a.actual_parameters]) for a in step]
                        for step in plan.steps]))
        except BaseException as exc:  # noqa: BLE001 - carried to the parent, raised there
            send.send(("error", repr(exc)))
    child = ctx.Process(target=work, daemon=True)
    child.start()
    try:
        if not recv.poll(timeout):
            return None
        message = recv.recv()
    finally:
        if child.is_alive():
            child.kill()
        child.join()
    if message[0] == "error":
        raise RuntimeError(f"cplus failed: {message[1]}")
    from unified_planning.plans import ActionInstance

    from cplus.pddl.solve import PddlPlan
    _, status, proved, optimal, cost, steps = message
    rebuilt = [[ActionInstance(problem.action(name), tuple(problem.object(o) for o in args)) for name, args in step]
               for step in steps]
    action_costs = any(m.is_minimize_action_costs() for m in problem.quality_metrics)
    return PddlPlan(problem, status, rebuilt, len(rebuilt) if status == "found" else None, proved, cost,
                    action_costs, optimal, engine.sequential)
