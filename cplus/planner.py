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

from collections.abc import Callable, Iterator
from enum import Enum

from cplus.ground.theory import GroundTheory
from cplus.history import History, decode_history
from cplus.program import QuerySpec
from cplus.record import Record
from cplus.sat.horizon import HorizonStats, QuerySession
from cplus.sat.solver import DEFAULT_SOLVER

__all__ = ["PlanStatus", "QueryResult", "run_query", "find_horizon", "iter_histories", "states_query",
           "QuerySession", "Session"]


class PlanStatus(Enum):
    FOUND = "found"
    NO_PLAN = "no_plan"          # no history anywhere in the maxstep range
    HORIZON_LIMIT = "horizon_limit"   # an open range stopped at --max-horizon


class QueryResult(Record):
    _fields = ("label", "status", "maxstep", "histories", "failed", "stats", "template_s", "complete", "solutions")

    label: str
    status: PlanStatus
    maxstep: int | None
    histories: list[History]
    failed: list[int]
    stats: list[HorizonStats]
    template_s: float
    complete: bool          # all requested solutions found (or all that exist)
    solutions: int             # how many were asked for (0 = all): 'Solution k:' headers unless 1
    nm = False              # the result of an nmquery (its label is an nmquery's): set by run_query

    def __init__(
            self,
            label: str,
            status: PlanStatus,
            maxstep: int | None,
            histories: list[History],
            failed: list[int] | None = None,
            stats: list[HorizonStats] | None = None,
            template_s: float = 0.0,
            complete: bool = True,
            solutions: int = 1) -> None:
        self.label = label
        self.status = status
        self.maxstep = maxstep
        self.histories = histories
        self.failed = [] if failed is None else failed
        self.stats = [] if stats is None else stats
        self.template_s = template_s
        self.complete = complete
        self.solutions = solutions


def states_query() -> QuerySpec:
    """CCALC's ``sat``: every state of the domain (maxstep 0, no conditions)."""
    return QuerySpec("states", 0, 0, (), None)


def run_query(theory: GroundTheory, query: QuerySpec, solutions: int = 1, solver: str = DEFAULT_SOLVER,
              max_horizon: int | None = None,
              on_horizon: Callable[[HorizonStats], None] | None = None,
              on_history: Callable[[History], None] | None = None) -> QueryResult:
    """Find the first maxstep in the query's range with a history, and ``solutions``
    histories there (0 = all of them).  Histories are distinct as histories: two models
    that differ only in auxiliary variables count once."""
    session = QuerySession(theory, query, solver, max_horizon, commit=True)
    failed = find_horizon(session, on_horizon)
    if session.found is None:
        status = PlanStatus.NO_PLAN if query.hi is not None else PlanStatus.HORIZON_LIMIT
        result = QueryResult(query.label, status, None, [], failed, session.stats, session.horizon.template_s)
        result.nm = query.nm
        return result
    histories: list[History] = []
    for hist in iter_histories(session):
        histories.append(hist)
        if on_history:
            on_history(hist)
        if solutions and len(histories) >= solutions:
            break
    session.stats[-1].models = len(histories)
    result = QueryResult(query.label, PlanStatus.FOUND, session.found, histories, failed, session.stats,
                         session.horizon.template_s, solutions=solutions)
    result.nm = query.nm
    return result


def find_horizon(session: QuerySession,
                 on_horizon: Callable[[HorizonStats], None] | None = None) -> list[int]:
    """Try the horizons of the query upwards; stop at the first with a history
    (``session.found``).  Returns the horizons without one."""
    failed: list[int] = []
    session.found = None
    for m in session.horizons():
        ok = session.solve_at(m)
        if on_horizon:
            on_horizon(session.stats[-1])
        if ok:
            session.found = m
            break
        failed.append(m)
    return failed


def iter_histories(session: QuerySession) -> Iterator[History]:
    """Every history at the session's current horizon, each once (the solver must have
    just found a model there)."""
    while True:
        yield decode_history(session)
        session.block_current()
        if not session.resolve():
            return


class Session(QuerySession):
    """A live solver for one query, for callers that enumerate histories or add constraints
    between solves (:meth:`cplus.Domain.session`).

    What a caller blocks stays blocked: :meth:`solve_at` at the horizon already solved solves
    again with every history blocked there still excluded (a :class:`QuerySession` would
    open the horizon afresh and drop them), a lower horizon is refused, and a higher one
    starts from what it allows.  :meth:`histories` is the loop that enumerates them.

    >>> from cplus import Domain
    >>> s = Domain.from_text('''
    ... :- constants lit :: inertialFluent; flip :: exogenousAction.
    ... flip causes lit.
    ... :- query maxstep :: 1; 1: lit.''').session()
    >>> s.solve_at(1), s.history().value("lit", 1)
    (True, True)
    >>> s.block_current(); s.solve_at(1)     # 3 histories: 2 are left
    True
    >>> len(list(s.histories(1)))            # those 2, each blocked as it is given
    2
    >>> s.solve_at(1)
    False
    """

    _solved: int | None = None      # the horizon opened last
    _model = False                  # the last solve found a history (the solver holds its model)

    def solve_at(self, m: int) -> bool:
        """Solve at horizon m: the query's conditions there, and every history blocked at m
        (:meth:`block_current`) still excluded.  Horizons only go up (ValueError below the
        last one)."""
        if self._solved is not None and m < self._solved:
            raise ValueError(f"horizon {m} is below {self._solved}, the one this session solved last: a session's "
                             "horizons only go up (start another with Domain.session)")
        if m == self._solved:
            return self.resolve()
        self._model = super().solve_at(m)
        return self._model

    def open_horizon(self, m: int) -> None:
        """Extend to a horizon above the current one without solving (ValueError at or below
        it: opening it again would drop what was blocked there)."""
        if self._solved is not None and m <= self._solved:
            raise ValueError(f"horizon {m} is already open (this session is at horizon {self._solved}): solve "
                             "again with solve_at or resolve, which keep what was blocked")
        super().open_horizon(m)
        self._solved, self._model = m, False

    def resolve(self) -> bool:
        """Solve again at the current horizon (after :meth:`block_current` or added clauses)."""
        if self._solved is None:
            raise ValueError("nothing to solve again: call solve_at(m) first")
        self._model = super().resolve()
        return self._model

    def _need_model(self, what: str) -> None:
        if self._solved is None:
            raise ValueError(f"no {what}: call solve_at(m) first")
        if not self._model:
            raise ValueError(f"no {what}: the last solve (horizon {self._solved}) found no history")

    def history(self) -> History:
        """The history the last solve found (ValueError when it found none)."""
        self._need_model("history")
        return decode_history(self)

    def block_current(self) -> None:
        """Exclude the history the last solve found, at this horizon, for the rest of the
        session (ValueError when it found none)."""
        self._need_model("history to block")
        super().block_current()

    def histories(self, m: int | None = None) -> Iterator[History]:
        """Every history at horizon m not blocked yet (None: the shortest horizon of the
        query's range that has one), each once and blocked as it is given."""
        if m is None:
            self.found = next((h for h in self.horizons()
                               if (self._solved is None or h >= self._solved) and self.solve_at(h)), None)
            if self.found is None:
                return
        elif not self.solve_at(m):
            return
        yield from iter_histories(self)
