"""Answer queries: search the maxstep range upwards, then collect histories.

>>> from cplus.load import load_text
>>> from cplus.ground.theory import ground_program
>>> prog = load_text('''
... :- constants lit :: inertialFluent; flip :: exogenousAction.
... flip causes lit.
... :- query maxstep :: 1; 1: lit.''')
>>> result = run_query(ground_program(prog), prog.queries[0], solutions=0)
>>> result.status.name, result.maxstep, len(result.histories)
('FOUND', 1, 3)
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Callable

from cplus.ground.theory import GroundTheory
from cplus.history import History, decode_history
from cplus.program import QuerySpec
from cplus.sat.horizon import HorizonStats, QuerySession
from cplus.sat.solver import DEFAULT_SOLVER

__all__ = ["PlanStatus", "QueryResult", "run_query", "states_query", "QuerySession"]


class PlanStatus(Enum):
    FOUND = "found"
    NO_PLAN = "no_plan"          # no history anywhere in the maxstep range
    HORIZON_LIMIT = "horizon_limit"   # an open range stopped at --max-horizon


@dataclass
class QueryResult:
    label: str
    status: PlanStatus
    maxstep: int | None
    histories: list[History]
    failed: list[int] = field(default_factory=list)
    stats: list[HorizonStats] = field(default_factory=list)
    template_s: float = 0.0
    complete: bool = True          # all requested solutions found (or all that exist)


def states_query() -> QuerySpec:
    """CCALC's ``sat``: every state of the domain (maxstep 0, no conditions)."""
    return QuerySpec("states", 0, 0, (), None, True)


def run_query(theory: GroundTheory, query: QuerySpec, solutions: int = 1, solver: str = DEFAULT_SOLVER,
              max_horizon: int | None = None,
              on_horizon: Callable[[HorizonStats], None] | None = None,
              on_history: Callable[[History], None] | None = None) -> QueryResult:
    """Find the first maxstep in the query's range with a history, and ``solutions``
    histories there (0 = all of them).  Histories are distinct as histories: two models
    that differ only in auxiliary variables count once."""
    session = QuerySession(theory, query, solver, max_horizon)
    failed: list[int] = []
    for m in session.horizons():
        ok = session.solve_at(m)
        if on_horizon:
            on_horizon(session.stats[-1])
        if not ok:
            failed.append(m)
            continue
        histories: list[History] = []
        while True:
            hist = decode_history(session)
            histories.append(hist)
            if on_history:
                on_history(hist)
            if solutions and len(histories) >= solutions:
                break
            session.block_current()
            t0 = time.perf_counter()
            more = session.horizon.solver.solve([session.act])  # type: ignore[list-item]
            session.stats[-1].solve_s += time.perf_counter() - t0
            if not more:
                break
        session.stats[-1].models = len(histories)
        return QueryResult(query.label, PlanStatus.FOUND, m, histories, failed, session.stats,
                           session.horizon.template_s)
    status = PlanStatus.NO_PLAN if query.hi is not None else PlanStatus.HORIZON_LIMIT
    return QueryResult(query.label, status, None, [], failed, session.stats, session.horizon.template_s)
