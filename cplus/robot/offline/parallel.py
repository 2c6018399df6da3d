"""Refinement on several processes: horizons at once, nogoods shared between the workers.

:func:`refine_parallel` gives what :func:`~cplus.robot.offline.refine.refine` gives (the
shortest collision-free plan, or the proof that there is none in the range), with the
horizons spread over worker processes by :func:`cplus.parallel.dispatch`.  Each worker checks
the plans its solvers propose (the continuous check runs where the plan is, so the parent
stays idle), learns nogoods from the violations, and teaches them to all its own sessions;
the parent sends them to every other worker.  A nogood forbids positions at every step of
every horizon, whatever the actions (that is what makes it sound), so it holds in every
worker's solvers as it holds in the one that learned it.

Every session gets the eager pre-check (behind its own guard) when it is made, and every
nogood known so far; the pre-check's account is the parent's own run of it.
"""
from __future__ import annotations

import time
from collections.abc import Callable

from cplus.history import decode_history
from cplus.parallel import DEFAULT_GAMMA, Strategy, Work, parallel_info, resolve_jobs, search
from cplus.robot.offline.nogoods import Nogood, NogoodStore
from cplus.robot.offline.refine import (
    DEFAULT_MAX_HORIZON,
    REFINE_SOLVER,
    Iteration,
    NogoodForm,
    Precheck,
    RefinementResult,
    RefineStatus,
    _check,
    _nogoods,
    _precheck,
)
from cplus.robot.offline.task import RobotTask, TaskError
from cplus.sat.horizon import HorizonStats, QuerySession

__all__ = ["ParallelRefinementResult", "refine_parallel"]


class ParallelRefinementResult(RefinementResult):
    """A :class:`RefinementResult` whose per-horizon statistics come from the workers, with
    the parallel search's account in :attr:`parallel` (the ``"parallel"`` JSON object)."""

    horizon_stats: list[HorizonStats]
    parallel: dict

    @property
    def stats(self) -> list[HorizonStats]:
        return self.horizon_stats

    def to_json(self, label: str | None = None) -> dict:
        doc = super().to_json(label)
        doc["parallel"] = self.parallel
        return doc


class _RobotWork(Work):
    """Sessions with the task's nogoods; a model is checked, and refuted or accepted."""

    def __init__(self, session: QuerySession, task: RobotTask, form: NogoodForm, eager: bool | None) -> None:
        super().__init__(session)
        self.task = task
        self.form = form
        self.eager = eager
        self.known: list[Nogood] = []
        self.keys: set[tuple] = set()
        self.stores: dict[int, tuple[NogoodStore, int | None]] = {}
        self.models: dict[int, tuple[int, int]] = {}   # session -> (horizon, models proposed there)
        self.precheck = self._teach(session)

    def prepare(self, session: QuerySession) -> None:
        self._teach(session)

    def _teach(self, session: QuerySession) -> Precheck | None:
        store = NogoodStore(session.horizon, self.theory.atoms)
        guard = None
        pre = None
        if self.form is NogoodForm.POSITIONS and self.eager is not False:
            guard = session.horizon.new_var()
            session.assumptions.append(guard)
            pre = _precheck(self.task, store, guard, bool(self.eager))
        for ng in self.known:
            store.add(ng)
        self.stores[id(session)] = (store, guard)
        return pre

    def _add(self, sessions: list[QuerySession], nogoods: list[Nogood]) -> list[Nogood]:
        new = [ng for ng in nogoods if ng.key not in self.keys]
        for ng in new:
            self.keys.add(ng.key)
            self.known.append(ng)
            for s in sessions:
                self.stores[id(s)][0].add(ng)
        return new

    def on_model(self, session: QuerySession, m: int, sessions: list[QuerySession]) -> tuple[bool, object]:
        t0 = time.perf_counter()
        last, count = self.models.get(id(session), (m, 0))
        self.models[id(session)] = (m, count + 1 if last == m else 1)
        hist = decode_history(session)
        states = self.task.states(hist)
        violations = _check(self.task, states, first_only=self.form is NogoodForm.ACTIONS)
        if not violations:
            return True, {"history": self.encode(hist), "seconds": time.perf_counter() - t0}
        new = self._add(sessions, _nogoods(self.task, hist, states, violations, self.form))
        if not new:   # cannot happen: the plan violates each of its nogoods, which the solver had
            raise TaskError(f"internal error: the solver proposed a plan of length {m} that its learned "
                            "nogoods forbid")
        return False, {"violations": violations, "learned": new, "seconds": time.perf_counter() - t0}

    def learn(self, sessions: list[QuerySession], learned: object) -> None:
        self._add(sessions, learned["learned"])   # type: ignore[index]

    def on_unsat(self, session: QuerySession, m: int) -> object:
        """Whether the domain has a plan at this horizon, geometry aside."""
        if self.models.get(id(session), (None, 0))[0] == m:
            return True
        guard = self.stores[id(session)][1]
        solver = session.horizon.solver
        if guard is not None and guard in solver.core():
            t0 = time.perf_counter()
            found = solver.solve([session.act])
            session.stats[-1].solve_s += time.perf_counter() - t0
            return found
        return False


def refine_parallel(task: RobotTask, label: str = "0", max_iterations: int | None = None,
                    max_horizon: int | None = None, solver: str | None = None, *, jobs: int | str = 2,
                    strategy: Strategy | str = Strategy.A, gamma: float = DEFAULT_GAMMA, any_length: bool = False,
                    nogoods: NogoodForm | str = NogoodForm.POSITIONS, eager: bool | None = None,
                    on_iteration: Callable[[Iteration], None] | None = None,
                    on_horizon: Callable[[HorizonStats], None] | None = None,
                    on_precheck: Callable[[Precheck], None] | None = None,
                    on_record: Callable[[dict], None] | None = None) -> ParallelRefinementResult:
    """:func:`~cplus.robot.offline.refine.refine` on ``jobs`` worker processes (``"auto"``: the
    cores there are).  ``on_horizon`` is accepted for the same signature; per-horizon reports
    come through ``on_record`` (one per worker and horizon)."""
    strategy = Strategy(strategy)
    form = NogoodForm(nogoods)
    domain = task.domain
    query = domain.query(label)  # type: ignore[attr-defined]
    task.check_start_goal(query)
    if query.hi is None and max_horizon is None:
        max_horizon = DEFAULT_MAX_HORIZON
    n = resolve_jobs(jobs)
    session = QuerySession(domain.theory, query, solver or REFINE_SOLVER, max_horizon)  # type: ignore[attr-defined]
    work = _RobotWork(session, task, form, eager)
    result = ParallelRefinementResult(RefineStatus.NO_PLAN, query, form)
    result.precheck = work.precheck
    if on_precheck and work.precheck is not None:
        on_precheck(work.precheck)

    def on_learned(wid: int, m: int, learned: object) -> bool:
        info: dict = learned   # type: ignore[assignment]
        it = Iteration(len(result.iterations) + 1, m, tuple(info["violations"]), tuple(info["learned"]),
                       info["seconds"])
        result.iterations.append(it)
        if on_iteration:
            on_iteration(it)
        return bool(max_iterations and len(result.iterations) >= max_iterations)

    out = search(work, n, strategy, gamma, 1, any_length, on_record, on_learned)
    top = out.maxstep if out.maxstep is not None else float("inf")
    stats = [HorizonStats(r["maxstep"], r["variables"], r["clauses"], r["encode_s"], r["solve_s"],
                          r["result"] == "sat") for r in sorted(out.records, key=lambda r: r["maxstep"])
             if r["result"] in ("sat", "unsat") and r["maxstep"] <= top]
    result.horizon_stats = stats
    result.parallel = parallel_info(out.workers, strategy, gamma, any_length, None, out.unproved, out.records,
                                    out.replaced, not out.unproved, asked=n)
    hi = query.hi if query.hi is not None else max_horizon
    limit = "" if query.hi is not None else " (--max-horizon)"
    if out.stopped_early:
        last = result.iterations[-1].maxstep
        result.no_solution_with_maxstep = [m for m in out.proved if m < last]
        result.horizon = last
        result.status = RefineStatus.GAVE_UP
        result.reason = (f"gave up after {len(result.iterations)} refinement iterations (--max-iterations) "
                         f"on {n} workers, the last at maxstep {last}")
        return result
    if out.maxstep is not None:
        payload: dict = out.payload   # type: ignore[assignment]
        hist = work.decode(payload["history"])
        result.history, result.states = hist, task.states(hist)
        result.no_solution_with_maxstep = [m for m in out.proved if m < out.maxstep]
        result.horizon = out.maxstep
        it = Iteration(len(result.iterations) + 1, out.maxstep, (), (), payload["seconds"])
        result.iterations.append(it)
        if on_iteration:
            on_iteration(it)
        result.status = RefineStatus.FOUND
        return result
    result.no_solution_with_maxstep = list(out.proved)
    result.horizon = out.proved[-1] if out.proved else None
    if result.iterations or any(out.extras.values()):
        result.status = RefineStatus.NO_SAFE_PLAN
        result.reason = f"no collision-free plan with maxstep {query.lo}..{hi}{limit}"
    else:
        result.status = RefineStatus.NO_PLAN if query.hi is not None else RefineStatus.HORIZON_LIMIT
        result.reason = f"no plan with maxstep {query.lo}..{hi}{limit}"
    return result
