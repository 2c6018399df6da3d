"""The refinement loop (the paper's Algorithm 1): plan, check continuously, forbid, re-plan.

After each plan the continuous checker walks the steps; at the first violation between steps
i and i+1 it reports the positions L (every bound coordinate at step i) and the actions A
executed at step i; the planner then forbids "exactly A while the robots and the payload are
at L" at every transition, by clauses added to the same live solver, and solves again, at
longer horizons when the current one runs out.

The paper forbids the conjunction of the executed actions only, which also forbids every
larger action set (a diagonal move that contains the blocked straight one, say); we forbid
the exact set (each action's truth value and the attributes of the executed ones), so no
collision-free motion is lost.

The result carries a :class:`RefineStatus`; the command line maps it to an exit code, and
:meth:`RefinementResult.to_json` is the robot-task form of a ``cplus.plan/1`` result.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum

from cplus.history import History, decode_history
from cplus.planner import find_horizon
from cplus.program import QuerySpec
from cplus.robot.task import RobotTask, TaskError
from cplus.sat.horizon import QuerySession

__all__ = ["DEFAULT_MAX_HORIZON", "Iteration", "RefineStatus", "RefinementResult", "refine"]

DEFAULT_MAX_HORIZON = 40
"""Where an open maxstep range (``N..infinity``) stops during refinement unless told."""


class RefineStatus(StrEnum):
    """How a refinement ended (the ``status`` of its JSON result)."""

    FOUND = "found"                    # a collision-free plan
    UNSAFE = "unsafe"                  # refinement off, and the first plan has a violation
    NO_SAFE_PLAN = "no_safe_plan"      # plans exist, none collision-free in the horizon range
    NO_PLAN = "no_plan"                # no plan at all in the query's maxstep range
    HORIZON_LIMIT = "horizon_limit"    # no plan up to --max-horizon of an open range


@dataclass
class Iteration:
    """One pass of the loop: the plan's length, its first violation, what was forbidden."""

    number: int
    maxstep: int
    violation: object | None       # trajectory.Violation
    actions: list[str] = field(default_factory=list)
    where: list[str] = field(default_factory=list)
    seconds: float = 0.0

    def text(self) -> str:
        if self.violation is None:
            return f"% refinement {self.number}: plan of length {self.maxstep} is collision-free"
        v = self.violation
        acts = "  ".join(self.actions) or "no action"
        return (f"% refinement {self.number}: plan of length {self.maxstep}: {v.kind.value} between steps "  # type: ignore[attr-defined]
                f"{v.step} and {v.step + 1}: {v.message}\n"  # type: ignore[attr-defined]
                f"%   forbidding {{{acts}}} where {', '.join(self.where)}")

    def to_json(self) -> dict:
        v = self.violation
        return {"iteration": self.number, "maxstep": self.maxstep,
                "violation": None if v is None else {
                    "kind": v.kind.value, "step": v.step, "u": v.u,  # type: ignore[attr-defined]
                    "point": list(v.point), "subject": v.subject,  # type: ignore[attr-defined]
                    "message": v.message},  # type: ignore[attr-defined]
                "forbidden_actions": self.actions, "where": self.where}


@dataclass
class RefinementResult:
    """What :func:`refine` found: the refined plan (or why there is none) and every iteration."""

    status: RefineStatus
    history: History | None
    states: list | None
    iterations: list[Iteration]
    first_history: History | None
    first_states: list | None
    first_violation: object | None
    reason: str = ""
    no_solution_with_maxstep: list[int] = field(default_factory=list)
    session: QuerySession | None = None

    @property
    def found(self) -> bool:
        return self.history is not None

    @property
    def shown(self) -> History | None:
        """The plan to print: the refined one, or the unsafe first plan when refinement is off."""
        return self.history or (self.first_history if self.status is RefineStatus.UNSAFE else None)

    def to_json(self, label: str) -> dict:
        from cplus.output import history_json
        hist = self.shown
        return {
            "query": {"label": label},
            "status": self.status.value,
            "maxstep": hist.maxstep if hist else None,
            "histories": [history_json(hist)] if hist else [],
            "refinement": [it.to_json() for it in self.iterations],
            "reason": self.reason or None,
        }


def refine(task: RobotTask, label: str = "0", max_iterations: int = 100, max_horizon: int | None = None,
           solver: str | None = None, refine: bool = True,
           on_iteration: Callable[[Iteration], None] | None = None,
           on_horizon: Callable | None = None, session: QuerySession | None = None) -> RefinementResult:
    """Algorithm 1: plan, check continuously, forbid, plan again in the same solver.

    ``session``: a live solver to refine in, instead of a new one for the query ``label`` (the
    online monitor plans from a state the arms were found in, with the clauses earlier
    refinements learned)."""
    import trajectory
    from cplus.sat.solver import DEFAULT_SOLVER
    domain = task.domain
    query = domain.query(label)  # type: ignore[attr-defined]
    task.check_start_goal(query)
    if query.hi is None and max_horizon is None:
        max_horizon = DEFAULT_MAX_HORIZON
    if session is None:
        session = QuerySession(domain.theory, query, solver or DEFAULT_SOLVER, max_horizon)  # type: ignore[attr-defined]
    else:
        query, max_horizon = session.query, session.max_horizon
    failed = find_horizon(session, on_horizon)
    result = RefinementResult(RefineStatus.NO_PLAN, None, None, [], None, None, None,
                              no_solution_with_maxstep=list(failed), session=session)
    if session.found is None:
        result.reason = _exhausted(query, max_horizon)
        if query.hi is None:
            result.status = RefineStatus.HORIZON_LIMIT
        return result

    def finish(it: Iteration, t0: float, status: RefineStatus, reason: str = "") -> RefinementResult:
        it.seconds = time.perf_counter() - t0
        result.iterations.append(it)
        if on_iteration:
            on_iteration(it)
        result.status, result.reason = status, reason
        if status is RefineStatus.NO_SAFE_PLAN:
            result.no_solution_with_maxstep = sorted({st.maxstep for st in session.stats})
        return result

    number = 0
    while True:
        number += 1
        t0 = time.perf_counter()
        hist = decode_history(session)
        states = task.states(hist)
        try:
            violation = trajectory.first_violation(task.scene, states)  # type: ignore[arg-type]
        except trajectory.TrajectoryError as exc:
            raise TaskError.from_trajectory(exc) from None
        if result.first_history is None:
            result.first_history, result.first_states, result.first_violation = hist, states, violation
        if violation is None:
            result.history, result.states = hist, states
            return finish(Iteration(number, hist.maxstep, None), t0, RefineStatus.FOUND)
        if not refine:
            return finish(Iteration(number, hist.maxstep, violation), t0, RefineStatus.UNSAFE,
                          "refinement is off (--no-refine)")
        pf, acts, where = task.forbidden(hist, violation.step)
        session.horizon.forbid_everywhere(pf)
        it = Iteration(number, hist.maxstep, violation, acts, where)
        if number >= max_iterations:
            return finish(it, t0, RefineStatus.NO_SAFE_PLAN,
                          f"no collision-free plan after {max_iterations} refinement iterations")
        ok = session.resolve()
        while not ok:
            nxt = session.horizon.m + 1
            if session.query.hi is not None and nxt > session.query.hi or \
                    max_horizon is not None and nxt > max_horizon:
                return finish(it, t0, RefineStatus.NO_SAFE_PLAN,
                              "no collision-free plan: " + _exhausted(query, max_horizon))
            ok = session.solve_at(nxt)
            if on_horizon:
                on_horizon(session.stats[-1])
        it.seconds = time.perf_counter() - t0
        result.iterations.append(it)
        if on_iteration:
            on_iteration(it)


def _exhausted(query: QuerySpec, max_horizon: int | None) -> str:
    hi = query.hi if query.hi is not None else max_horizon
    return f"no plan with maxstep {query.lo}..{hi}" + (" (--max-horizon)" if query.hi is None else "")
