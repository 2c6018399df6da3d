"""A query of a plain domain answered on several processes: :func:`solve_parallel`.

The result is the sequential planner's :class:`~cplus.planner.QueryResult` (same maxstep,
same ``failed`` horizons, the same histories for ``solutions=0``), with what the parallel
search adds in :attr:`ParallelResult.parallel`.

``jobs="auto"`` uses every core this process may run on, and starts out as the sequential
planner does, in this process (the same session, committing to slow horizons the same way):
on an easy instance no worker is ever started, so it costs what the sequential planner
costs.  Once a horizon's solve takes :data:`AUTO_SWITCH_S` or more, the remaining horizons
go to workers forked from this process, each inheriting the live session (what its solver
learned included) and extending it upwards.  The workers then run strategy B unless told (:data:`~cplus.parallel.strategy.DEFAULT_STRATEGY`).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from cplus.options import check_gamma, check_jobs, check_strategy, named
from cplus.parallel.strategy import DEFAULT_GAMMA, DEFAULT_STRATEGY, Strategy, available_cores
from cplus.planner import PlanStatus, QueryResult
from cplus.sat.horizon import HorizonStats, QuerySession
from cplus.sat.solver import DEFAULT_SOLVER

if TYPE_CHECKING:
    from cplus.parallel.work import Outcome

__all__ = ["ParallelResult", "solve_parallel", "resolve_jobs", "AUTO_SWITCH_S", "parallel_info"]

AUTO_SWITCH_S = 1.0
"""``--jobs auto`` goes parallel after a horizon whose solve took this long (seconds), and
only when it took longer than the one before (the horizons are getting harder).  Going
parallel is not free: every worker encodes every step again, a solver that skips horizons
has learned less, and two solvers at once each run slower (docs/parallel.md): on
ferryman-30-4, whose 57 horizons take at most 0.6 s each, strategy A on two workers took
more processor time and more wall time than the sequential search.  On every corpus
benchmark each horizon is below this, so ``auto`` stays in this process."""


class ParallelResult(QueryResult):
    """A :class:`QueryResult` with the parallel search's account: ``parallel`` is the
    ``"parallel"`` object of the ``cplus.plan/1`` result (README)."""

    parallel: dict

    @property
    def proved_shortest(self) -> bool:
        return bool(self.parallel.get("proved_shortest", True))


def resolve_jobs(jobs: int | str) -> int:
    """``"auto"``: the cores this process may use; otherwise the number itself."""
    return available_cores() if jobs == "auto" else int(jobs)


def solve_parallel(domain, label: str = "0", solutions: int = 1, solver: str = DEFAULT_SOLVER,
                   max_horizon: int | None = None, *, jobs: int | str = 2,
                   strategy: Strategy | str = DEFAULT_STRATEGY, gamma: float = DEFAULT_GAMMA, any_length: bool = False,
                   on_record: Callable[[dict], None] | None = None,
                   on_horizon: Callable[[HorizonStats], None] | None = None) -> ParallelResult:
    """Answer query ``label`` of a :class:`~cplus.api.Domain` on ``jobs`` worker processes
    (see the module's docstring for ``"auto"``).  ``on_record`` hears each (worker, horizon)
    record as it ends; ``on_horizon`` each horizon solved in this process (``auto``)."""
    jobs = named("jobs", check_jobs, jobs)
    strategy = Strategy(named("strategy", check_strategy, strategy.value if isinstance(strategy, Strategy) else strategy))
    gamma = named("gamma", check_gamma, gamma)
    query = domain.query(label)
    theory = domain.theory_for(query)
    n = resolve_jobs(jobs)
    auto = jobs == "auto"
    session = QuerySession(theory, query, solver, max_horizon, commit=auto)
    failed: list[int] = []
    switched: int | None = None
    if auto:
        for m in session.horizons():
            ok = session.solve_at(m)
            st = session.stats[-1]
            if on_horizon:
                on_horizon(st)
            if ok:
                return _sequential_answer(session, query, solutions, failed, n, strategy, gamma, any_length)
            failed.append(m)
            before = session.stats[-2].solve_s if len(session.stats) > 1 else 0.0
            if n > 1 and st.solve_s >= AUTO_SWITCH_S and st.solve_s > before:
                switched = m + 1
                break
        else:
            return _sequential_answer(session, query, solutions, failed, n, strategy, gamma, any_length)
        session.query = _from(query, switched)
        session.commit = False
    from cplus.parallel.dispatch import search
    from cplus.parallel.work import Work
    work = Work(session)
    out = search(work, n, strategy, gamma, solutions, any_length, on_record)
    session.query = query
    return _result(query, out, session.stats, failed, work.template_s, solutions, n, strategy, gamma,
                   any_length, switched)


def _from(query, lo: int):
    """The query with its range starting at ``lo`` (the horizons below are done)."""
    from cplus.program import QuerySpec
    return QuerySpec(query.label, lo, query.hi, query.items, query.loc)


def _sequential_answer(session: QuerySession, query, solutions: int, failed: list[int], n: int,
                       strategy: Strategy, gamma: float, any_length: bool) -> ParallelResult:
    """``auto`` ended in this process: the sequential planner's answer, as it gives it."""
    from cplus.planner import iter_histories
    if session.stats and session.stats[-1].satisfiable:
        m = session.stats[-1].maxstep
        session.found = m
        histories = []
        for hist in iter_histories(session):
            histories.append(hist)
            if solutions and len(histories) >= solutions:
                break
        session.stats[-1].models = len(histories)
        result = ParallelResult(query.label, PlanStatus.FOUND, m, histories, failed, session.stats,
                                session.horizon.template_s, solutions=solutions)
    else:
        status = PlanStatus.NO_PLAN if query.hi is not None else PlanStatus.HORIZON_LIMIT
        result = ParallelResult(query.label, status, None, [], failed, session.stats, session.horizon.template_s,
                                solutions=solutions)
    result.parallel = parallel_info(n, strategy, gamma, any_length, None, [], [], 0, True)
    return result


def _result(query, out: Outcome, before: list[HorizonStats], failed: list[int], template_s: float, solutions: int,
            n: int, strategy: Strategy, gamma: float, any_length: bool, switched: int | None) -> ParallelResult:
    stats = list(before)
    top = out.maxstep if out.maxstep is not None else float("inf")
    for r in sorted(out.records, key=lambda r: r["maxstep"]):
        # as the sequential search's: the horizons up to the answer (the rest is in "runs")
        if r["result"] in ("sat", "unsat") and r["maxstep"] <= top:
            stats.append(HorizonStats(r["maxstep"], r["variables"], r["clauses"], r["encode_s"], r["solve_s"],
                                      r["result"] == "sat", len(out.histories) if r["maxstep"] == out.maxstep else 0))
    proved = failed + out.proved
    if out.maxstep is not None:
        result = ParallelResult(query.label, PlanStatus.FOUND, out.maxstep, out.histories,
                                [m for m in proved if m < out.maxstep], stats, template_s, solutions=solutions)
    else:
        status = PlanStatus.NO_PLAN if query.hi is not None else PlanStatus.HORIZON_LIMIT
        result = ParallelResult(query.label, status, None, [], proved, stats, template_s, solutions=solutions)
    result.parallel = parallel_info(out.workers, strategy, gamma, any_length, switched, out.unproved, out.records,
                                    out.replaced, not out.unproved, asked=n)
    return result


def parallel_info(n: int, strategy: Strategy, gamma: float, any_length: bool, switched: int | None,
                  unproved: list[int], records: list[dict], replaced: int, proved_shortest: bool,
                  asked: int | None = None) -> dict:
    """The ``"parallel"`` object of a ``cplus.plan/1`` result: ``jobs`` the workers the search
    started (``n``), ``jobs_asked`` how many were asked for (``--jobs``; more than started when
    fewer horizons can run at once, or beyond the bound per core)."""
    return {"jobs": n, "jobs_asked": n if asked is None else asked, "strategy": strategy.value, "gamma": gamma if strategy is Strategy.B else None,
            "any_length": any_length, "proved_shortest": proved_shortest, "not_proved_empty": list(unproved),
            "parallel_from": switched, "workers_replaced": replaced,
            "runs": [{k: round(v, 6) if isinstance(v, float) else v for k, v in r.items()} for r in records]}
