"""Planning for a standing goal on one solver per run, within a budget.

A server keeps a robot working towards a *standing goal* ("nothing pending") while requests
re-open it. Every request and cancellation means a re-plan, and a re-plan must be quick:
:meth:`OnlineModel.plan` builds a fresh solver each time (encoding every step again), and the
shortest plan for many requests at once is a hard search. This module answers both:

* **One solver per run.** :class:`StandingPlanner` instantiates the step templates once, up
  to the longest horizon needed so far (extended on demand), with every event false at every
  step. A state is a set of assumptions at step 0, and "the goal holds at some step ``j <= m``"
  is one activation literal per ``m``. A re-plan is solving with those assumptions, and what
  the solver learned about the domain in earlier cycles stays. Reaching the goal by step ``m``
  is monotone in ``m``, so the shortest horizon is found by galloping from a hint (the last
  plan's length for that goal, less the steps executed since: two solver calls when it is
  still right) and halving, instead of trying every horizon from 0. The steps after a plan's
  end belong to the encoding too: this assumes that from every state the robot can reach,
  some step is possible (in a domain where doing nothing is always possible, as with
  inertial fluents and no law that forces an action, that holds).
* **A budget, then the goals in order.** The shortest plan for the whole goal is searched
  within a budget of unit propagations (a measure of the solver's work that follows time,
  but gives the same answer on a loaded machine), on the steps encoded so far. Within it,
  the plan is the shortest. When the budget runs out (many requests in flight), the plan is
  the shortest one that closes the *oldest open goal*, which is found first anyway (its
  length bounds the whole goal's from below). Such a plan is *partial*
  (:attr:`Plan.partial`): the online loop plans again when it has been carried out, and that
  plan again tries the whole goal first, unless the budget ran out the last time with as
  many goals open. Goals are closed in the order they arrived, each by a shortest plan;
  none is starved.

What a goal is comes from the caller: ``agenda()`` returns the open goals oldest first, each
as the literal that says it is done (``pending(3)`` false). Without an agenda the planner
only ever plans for the whole goal, exactly (no budget).

>>> from cplus.api import Domain
>>> from cplus.robot.online import OnlineModel, Roles
>>> d = Domain.from_text('''
... :- constants lit :: inertialFluent; flip, kick :: exogenousAction.
... flip causes lit.  kick causes -lit.
... :- query label :: on; maxstep :: 0..3; 0: -lit; maxstep: lit.''')
>>> m = StandingModel(d, "on", Roles.of(d, observed=["kick"]))
>>> s0 = m.initial_state().state
>>> m.plan(s0).texts()
[['flip']]
>>> m.plan(m.estimate(s0, m.plan(s0).steps[0]).state).texts()
[]
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from cplus.history import History, from_object
from cplus.robot.online import OnlineModel, Plan, Roles, State
from cplus.sat.horizon import QuerySession
from cplus.sat.solver import DEFAULT_SOLVER
from cplus.signature import GroundConst

__all__ = ["DEFAULT_BUDGET", "GoalLiteral", "PlannerStats", "StandingModel", "StandingPlanner"]

DEFAULT_BUDGET = 250_000
"""Unit propagations for the shortest plan of the whole goal, per re-plan (some 20 ms of
solving on the machines this was measured on)."""


@dataclass(frozen=True)
class GoalLiteral:
    """One open goal of the agenda: it is done when ``gc`` has ``value`` (``pending(3)`` false).
    ``tag`` tells goals apart that use the same literal one after the other (a goal id)."""

    gc: GroundConst
    value: object
    tag: object = None


@dataclass
class PlannerStats:
    """What the last :meth:`StandingPlanner.plan` did: solver calls, propagations spent on the
    whole goal, how the plan was found (``"shortest"``: the whole goal, proved shortest;
    ``"oldest goal"``: the budget ran out, and the plan is the shortest that closes the oldest
    open goal), its length, the time spent solving and encoding new steps, and the steps
    encoded afterwards."""

    calls: int = 0
    propagations: int = 0
    how: str = ""
    length: int = 0
    seconds: float = 0.0
    solve_s: float = 0.0
    encode_s: float = 0.0
    encoded: int = 0


class _Session(QuerySession):
    """A query session whose goal literal for horizon ``m`` is kept (not retired) and that
    never retires earlier horizons: any of them can be asked again."""

    def goal_at(self, m: int) -> int:
        self._add_items(m)
        assert self.act is not None
        return self.act


class StandingPlanner:
    """Shortest plans from the states of one run, on one incremental solver.

    Args:
        model: the run's model (its theory, templates, roles and goal query).
        budget: unit propagations allowed for the whole goal per plan (None: no limit, always
            the shortest plan).
        horizon: steps to encode at once (default: up to 20, or the goal's maxstep range);
            more are added when a plan needs them.
    """

    def __init__(self, model: OnlineModel, budget: int | None = DEFAULT_BUDGET, horizon: int | None = None) -> None:
        self.model = model
        self.budget = budget
        self.hi = model.goal_query.hi if model.goal_query.hi is not None else 0
        self.session = _Session(model.theory, model.goal_query, model.solver, templates=model.templates)
        self.h = self.session.horizon
        self.solver = self.h.solver
        atoms = model.atoms
        agent = model.roles.agent
        self._action_gcs = sorted([gc for gc in model.domain.program.signature.ground
                                   if gc in agent or (gc.decl.kind == "attribute" and any(
                                       p.decl is gc.decl.parent and gc.args[:p.decl.arity] == p.args
                                       for p in agent))], key=lambda g: g.id)
        self._events = [aid for gc in sorted(model.roles.events, key=lambda g: g.id)
                        for aid, v in atoms.head_lits(gc) if v not in ("false", "none") and aid > 0]
        self._forbidden = 0               # transitions whose events are forbidden
        self._goal: dict[int, int] = {}   # m -> the goal holds at step m (guarded)
        self._reach: dict[tuple[object, int], int] = {}   # (goal key, m) -> done at some step <= m
        self._last: dict[object, tuple[int, int]] = {}     # goal key -> (length of its last plan, at step)
        self.steps = 0            # steps executed in the run (the loop's estimates count them)
        self._lengths: list[int] = []    # the last plans' lengths for single goals
        self._hard = 1 << 30      # open goals for which the whole goal could not be found in the budget
        self.stats = PlannerStats()
        self.extend(min(self.hi, 20) if horizon is None else min(horizon, self.hi))

    # ------------------------------------------------------------------ the encoding
    def extend(self, m: int) -> None:
        """Encode the steps up to ``m`` (only upwards), events false at every transition."""
        h = self.h
        if m <= h.m:
            return
        t0 = time.perf_counter()
        h.extend_to(m)
        add = self.solver.add_clause
        while self._forbidden < h.m:
            t = self._forbidden
            for aid in self._events:
                add([-h.var(aid, t)])
            self._forbidden += 1
        self.stats.encode_s += time.perf_counter() - t0

    def _goal_at(self, m: int) -> int:
        lit = self._goal.get(m)
        if lit is None:
            self.extend(m)
            lit = self._goal[m] = self.session.goal_at(m)
        return lit

    def _done_at(self, key: object, t: int) -> int:
        """The literal: goal ``key`` (None: the whole goal, or a :class:`GoalLiteral`) holds at step t."""
        if key is None:
            return self._goal_at(t)
        assert isinstance(key, GoalLiteral)
        self.extend(t)
        return self.model._lit(self.h, key.gc, key.value, t)

    def _reached(self, key: object, m: int) -> int:
        """An assumption literal: goal ``key`` holds at some step ``j <= m``."""
        lit = self._reach.get((key, m))
        if lit is None:
            clause = [self._done_at(key, j) for j in range(m + 1)]
            lit = self.h.new_var()
            self.solver.add_clause([-lit] + clause)
            self._reach[(key, m)] = lit
        return lit

    # ------------------------------------------------------------------ search
    def _solve(self, assumptions: list[int], budget: list[int] | None) -> bool | None:
        self.stats.calls += 1
        t0 = time.perf_counter()
        if budget is None:
            ok = self.solver.solve(assumptions)
        elif budget[0] <= 0:
            return None
        else:
            before = self.solver.propagations
            ok = self.solver.solve_limited(assumptions, budget[0])
            used = self.solver.propagations - before
            budget[0] -= used
            self.stats.propagations += used
        self.stats.solve_s += time.perf_counter() - t0
        return ok

    def _shortest(self, start: list[int], key: object, lo: int, budget: list[int] | None,
                  top: int | None = None) -> int | None:
        """The least ``m`` in ``lo..top`` (default: the goal's maxstep) at which goal ``key`` is
        reached from ``start``, leaving that horizon's model in the solver; None when there is
        none, or when the budget ran out first. Horizons below ``lo`` are known not to reach it.

        Reaching the goal at some step up to ``m`` is monotone in ``m``: the search gallops
        from a guess down or up, then halves the gap. The guess is the length of the last plan
        for this goal less the steps executed since (when it is still right, that is two solver
        calls); for a goal not planned for yet, the median length of the last plans for single
        goals (a probe far above the answer costs more than several below it)."""
        hi = self.hi if top is None else min(top, self.hi)
        if lo > hi:
            return None
        model_at: list[int | None] = [None]

        def reaches(m: int) -> bool | None:
            ok = self._solve(start + [self._reached(key, m)], budget)
            model_at[0] = m if ok else None
            return ok

        last = self._last.get(key)
        if last is not None and last[0] - (self.steps - last[1]) < lo:
            last = None                           # that plan is over: no hint
        bad, step = lo - 1, 1
        if last is not None:
            guess = last[0] - (self.steps - last[1])
        elif self._lengths:                       # a goal not planned for yet: as long as the last few
            guess = sorted(self._lengths)[len(self._lengths) // 2]
        else:
            guess = self.h.m
        first = max(lo, min(guess, hi))
        ok = reaches(first)                       # gallop from the guess, down or up
        if ok is None:
            return None
        good: int | None = None
        if ok:
            good = first
            while good - bad > 1:
                m = max(bad + 1, good - step)
                ok = reaches(m)
                if ok is None:
                    return None
                if not ok:
                    bad = m
                    break
                good, step = m, step * 2
        else:
            bad = first
        while good is None:
            if bad >= hi:
                return None
            m = min(hi, bad + step)
            ok = reaches(m)
            if ok is None:
                return None
            if ok:
                good = m
            else:
                bad, step = m, step * 2
        while good - bad > 1:                     # halve the gap
            mid = (bad + good) // 2
            ok = reaches(mid)
            if ok is None:
                return None
            if ok:
                good = mid
            else:
                bad = mid
        if model_at[0] != good and not self._solve(start + [self._reached(key, good)], None):
            raise AssertionError("reaching the goal is not monotone in the horizon")  # pragma: no cover
        self._last[key] = (good, self.steps)
        if key is not None:
            self._lengths = (self._lengths + [good])[-8:]
        return good

    def plan(self, state: State, agenda: Sequence[GoalLiteral] = ()) -> Plan | None:
        """The shortest plan from ``state`` to the goal; with an ``agenda`` (open goals, oldest
        first) and a budget, the shortest plan that closes the oldest goal when the whole one
        takes longer to find. None when no plan exists within the goal's maxstep range (for
        the oldest goal, with an agenda)."""
        t0 = time.perf_counter()
        self.stats = PlannerStats()
        start = self.model._state_lits(self.h, state, 0)
        open_goals = [g for g in agenda if state.get(g.gc) != g.value]
        if not open_goals or self.budget is None:
            m = self._shortest(start, None, 0, None)
            if m is None:
                return None
            plan = self._read(self._first(None, m), partial=False)
            self.stats.how = "shortest"
        else:
            first = open_goals[0]
            lo = self._shortest(start, first, 0, None)     # a lower bound, and the fallback
            if lo is None:
                return None
            plan = self._read(self._first(first, lo), partial=True)
            # the whole goal within the budget, on the steps encoded so far; not tried again
            # for as many open goals as the last time it could not be found
            m = None
            if len(open_goals) < self._hard:
                m = self._shortest(start, None, lo, [self.budget], top=self.h.m)
                if m is None:
                    self._hard = len(open_goals)
            if m is not None:
                self._hard = max(self._hard, len(open_goals) + 1)
                plan = self._read(self._first(None, m), partial=False)
                self.stats.how = "shortest"
            else:
                end = plan.states[-1]
                plan.partial = any(end.get(g.gc) != g.value for g in open_goals[1:]) or not self._holds(end)
                self.stats.how = "oldest goal"
        self.stats.length = plan.length
        self.stats.encoded = self.h.m
        self.stats.seconds = plan.seconds = time.perf_counter() - t0
        return plan

    def _first(self, key: object, m: int) -> int:
        """The first step at which goal ``key`` holds in the current model (at most ``m``)."""
        value = self.solver.value
        for j in range(m + 1):
            lit = self._done_at(key, j)
            if (value(lit) if lit > 0 else not value(-lit)):
                return j
        return m

    def _holds(self, state: State) -> bool:
        """Does the whole goal hold in ``state`` (a plan of length 0)?"""
        return bool(self.solver.solve(self.model._state_lits(self.h, state, 0) + [self._goal_at(0)]))

    def _read(self, j: int, partial: bool) -> Plan:
        """The plan of the solver's current model, steps 0..j-1: the states and the agent's
        actions with their attributes (events are false in every plan)."""
        model, h = self.model, self.h
        states = [model._read_state(h, t) for t in range(j + 1)]
        tables = [{gc: self._value(gc, t) for gc in self._action_gcs} for t in range(j)]
        rigid = {gc: v for gc, v in states[0].items() if gc.decl.kind == "rigid"}
        history = History(j, {gc: from_object(gc, v) for gc, v in rigid.items()},
                          tuple({gc: from_object(gc, v) for gc, v in st.items() if gc not in rigid} for st in states),
                          tuple({gc: from_object(gc, v) for gc, v in table.items()} for table in tables))
        return Plan([model.acts(table) for table in tables], states, history, partial=partial)

    def _value(self, gc: GroundConst, t: int) -> object:
        value, var = self.solver.value, self.h.var
        pairs = self.model.atoms.head_lits(gc)
        if gc.boolean:
            return "true" if value(var(pairs[0][0], t)) else "false"
        return next((v for aid, v in pairs if value(var(aid, t))), "none")


class StandingModel(OnlineModel):
    """An :class:`OnlineModel` whose plans come from a :class:`StandingPlanner`: one solver for
    the whole run, a budget for the shortest plan, and the open goals (``agenda()``) in order
    when the budget runs out."""

    def __init__(self, domain, goal: str, roles: Roles, *, solver: str = DEFAULT_SOLVER,
                 max_horizon: int | None = None, budget: int | None = DEFAULT_BUDGET,
                 agenda: Callable[[], Sequence[GoalLiteral]] | None = None, horizon: int | None = None) -> None:
        super().__init__(domain, goal, roles, solver=solver, max_horizon=max_horizon)
        self.agenda = agenda or (lambda: ())
        self.planner = StandingPlanner(self, budget, horizon)

    def plan(self, state: State) -> Plan | None:
        return self.planner.plan(state, self.agenda())

    def estimate(self, state, acts, events=(), sensed=None):
        """:meth:`OnlineModel.estimate`; each one is a step of the run, so the planner's hints
        (the lengths of its last plans) can count down."""
        self.planner.steps += 1
        return super().estimate(state, acts, events, sensed)
