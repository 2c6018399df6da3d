"""Cost-optimal plans: ``cplus plan FILE --minimize TERM``.

TERM is an integer fluent (an additive cost, a level), or a sum of them, read at the last
step of a plan.  The optimum is found in the query's own live solver, with pysat's
incremental machinery rather than a MaxSAT loop of our own:

* **one constant**: "cost =< k" is one clause over the constant's value atoms at the last
  step (its values are one-hot already), behind a fresh literal that is *assumed*; nothing
  else is encoded, and every bound is a new assumption, so what the solver learned about
  the domain survives from one bound to the next;
* **a sum**: each constant's value is written in unary (order literals ``c >= v_min + j``,
  each implied by the value atoms above it), and pysat's incremental totalizer
  (:class:`pysat.card.ITotalizer`) counts them; "sum =< k" is the assumption that its
  output ``rhs[k - low]`` is false.

The search over bounds is SAT-UNSAT by default: each model's cost, minus one, is the next
bound, and the first unsatisfiable bound proves the last model optimal.  ``binary`` halves
the gap between the lower bound (raised by each unsatisfiable bound) and the best model.
Which is faster, and against RC2 (pysat's core-guided MaxSAT solver, on a copy of the
horizon's CNF), is measured in ``bench/bench_optimal.py`` and written up in
docs/optimization.md.

This module is imported only when ``--minimize`` is given: planning does not pay for it.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterator

from cplus.errors import CPlusError
from cplus.history import History, decode_history
from cplus.planner import PlanStatus, QueryResult, find_horizon
from cplus.record import Record
from cplus.sat.horizon import HorizonStats, QuerySession

__all__ = ["Objective", "Optimum", "OptimalResult", "CostBound", "improve", "run_optimal", "STRATEGIES",
           "Stopped", "Best", "solve_until", "optimum_text", "optimum_json", "optimum_fields", "line"]

STRATEGIES = ("linear", "binary")


class Stopped(Exception):
    """The deadline (``--time-limit``) passed inside a solve."""


class Objective:
    """The ground constants whose values, summed at the last step, are to be minimized."""

    def __init__(self, text: str, constants: list) -> None:
        self.text = text
        self.constants = constants

    @classmethod
    def parse(cls, text: str, sig, option: str = "--minimize") -> Objective:
        """``cost``, ``has(buyer,money)``, ``fuel(t1) + fuel(t2)``: ground constants named as
        the output prints them, joined by ``+``.  Refused in one line (exit 2) when a name is
        no constant, or not one with integer values; the message starts with ``option`` (the
        command's flag; the API gives none)."""
        lead = f"{option}: " if option else ""
        parts: list[str] = []
        cur: list[str] = []
        depth = 0
        for ch in text:
            if ch == "+" and depth == 0:
                parts.append("".join(cur))
                cur = []
                continue
            depth += ch == "("
            depth -= ch == ")"
            cur.append(ch)
        parts.append("".join(cur))
        by_text = {gc.text: gc for gc in sig.ground}
        constants = []
        for part in parts:
            name = "".join(part.split())
            gc = by_text.get(name)
            if gc is None:
                raise CPlusError(f"{lead}'{name or text}' is not a ground constant of this domain "
                                 "(write a fluent as the output prints it, e.g. cost or has(buyer,money), "
                                 "or a sum of them with +)")
            if gc.decl.is_action:
                raise CPlusError(f"{lead}'{name}' is an action; the term is read at the last state, so "
                                 "it must be a fluent (an additive fluent sums an action's costs)")
            if not gc.domain or not all(isinstance(v, int) for v in gc.domain):
                raise CPlusError(f"{lead}'{name}' does not have integer values (its domain is "
                                 f"{gc.decl.domain})")
            constants.append(gc)
        return cls(" + ".join("".join(p.split()) for p in parts), constants)

    def value(self, hist: History) -> int:
        last = hist.states[-1]
        return sum(int(hist.rigid[gc] if gc.decl.kind == "rigid" else last[gc])  # type: ignore[call-overload]
                   for gc in self.constants)


class CostBound:
    """"TERM =< k" as assumptions over the solver of ``session`` at horizon ``m`` (the
    horizon must have been extended to ``m``).

    An additive fluent is also bounded *flat*: its value at ``m`` is its value at 0 plus
    every contribution at steps 0..m-1 (the encoding's partial sums are exact, so this holds
    in every model), and a totalizer over those contributions gives the solver the count
    directly.  Proving that no plan is cheaper is a counting argument (bw-25: at least 29
    moves), which the chain of one-hot partial sums alone makes the solver rediscover step
    by step; with the flat count beside it the proof of bw-25's optimum is several times
    faster (docs/optimization.md)."""

    def __init__(self, session: QuerySession, objective: Objective, m: int, totalizer: bool = False,
                 flat: bool = True) -> None:
        self.session = session
        self.m = m
        self.terms: list[list[tuple[int, int]]] = []       # each TERM constant's value atoms at m
        pieces: list[list[tuple[int, int]]] = []           # what the totalizer sums
        sums = {s.target.id: s for s in session.theory.sums} if flat else {}
        for gc in objective.constants:
            t = None if gc.decl.kind == "rigid" else m
            self.terms.append(self._values(gc, t))
            s = sums.get(gc.id)
            if s is not None and gc.decl.kind == "additiveFluent":
                pieces.append(self._values(gc, 0))
                pieces.extend(self._values(c, step) for step in range(m) for c in s.contributions)
            else:
                pieces.append(self.terms[-1])
        self.low = sum(t[0][0] for t in self.terms)
        self.high = sum(t[-1][0] for t in self.terms)
        self._cache: dict[int, list[int]] = {}
        self._tot = None
        self._tot_low = sum(p[0][0] for p in pieces)
        if totalizer or len(pieces) > 1:
            self._tot = self._totalizer(pieces)

    def _values(self, gc, t: int | None) -> list[tuple[int, int]]:
        h = self.session.horizon
        return sorted((int(v), h.var(aid, t)) for aid, v in self.session.atoms.head_lits(gc))  # type: ignore

    def _totalizer(self, pieces: list[list[tuple[int, int]]]):
        from pysat.card import ITotalizer
        h = self.session.horizon
        add = h.solver.add_clause
        ys: list[int] = []
        for t in pieces:
            v0 = t[0][0]
            span = t[-1][0] - v0
            if span == 1:                     # a 0/1 piece counts its one atom
                ys.append(t[-1][1])
                continue
            order = [h.new_var() for _ in range(span)]      # order[j-1]: value >= v0 + j
            for j in range(1, span):
                add([-order[j], order[j - 1]])
            for v, x in t:
                if v > v0:
                    add([-x, order[v - v0 - 1]])
            ys.extend(order)
        if not ys:
            return None
        tot = ITotalizer(lits=ys, ubound=min(len(ys), self.high - self._tot_low + 1), top_id=h.top)
        h.top = tot.top_id
        for c in tot.cnf.clauses:
            add(c)
        return tot

    def at_most(self, k: int) -> list[int] | None:
        """Assumptions that make TERM =< k (``[]``: always true; ``None``: impossible)."""
        if k < self.low:
            return None
        if k >= self.high:
            return []
        got = self._cache.get(k)
        if got is None:
            got = []
            if len(self.terms) == 1:          # one constant: a clause over its value atoms
                h = self.session.horizon
                b = h.new_var()
                h.solver.add_clause([-b] + [x for v, x in self.terms[0] if v <= k])
                got.append(b)
            if self._tot is not None and k - self._tot_low < len(self._tot.rhs):
                got.append(-self._tot.rhs[k - self._tot_low])
            self._cache[k] = got
        return got

    def model_value(self) -> int:
        s = self.session.horizon.solver
        return sum(next(v for v, x in t if s.value(x)) for t in self.terms)


class Optimum(Record):
    """The best plan's cost, and whether it is proved optimal (else the lower bound known)."""

    _fields = ("term", "value", "proved", "lower_bound", "over_lengths", "proved_up_to", "stopped", "solves")

    term: str
    value: int
    proved: bool
    lower_bound: int
    over_lengths: bool
    proved_up_to: int | None      # --over-lengths: every length up to this one is searched
    stopped: str | None           # "time_limit" or "interrupted" when the proof was cut short
    solves: int

    def __init__(self, term: str, value: int, proved: bool, lower_bound: int, over_lengths: bool = False,
                 proved_up_to: int | None = None, stopped: str | None = None, solves: int = 0) -> None:
        self.term = term
        self.value = value
        self.proved = proved
        self.lower_bound = lower_bound
        self.over_lengths = over_lengths
        self.proved_up_to = proved_up_to
        self.stopped = stopped
        self.solves = solves


class OptimalResult(QueryResult):
    """A :class:`~cplus.planner.QueryResult` with the optimum of its plans (``None`` when
    there is no plan)."""

    _fields = QueryResult._fields + ("optimum",)  # type: ignore[assignment]
    optimum: Optimum | None

    def __init__(self, base: QueryResult, optimum: Optimum | None) -> None:
        super().__init__(base.label, base.status, base.maxstep, base.histories, base.failed, base.stats,
                         base.template_s, base.complete, base.solutions)
        self.optimum = optimum


def solve_until(session: QuerySession, assumptions: list[int], deadline: float | None) -> bool:
    """Solve at the session's horizon under its own assumptions and ``assumptions``; the
    time goes to the horizon's statistics.  With a deadline, in slices of a growing
    propagation budget (pysat has no clock; a slice keeps what the solver learned), so the
    deadline is kept to within a slice.  Raises :class:`Stopped` when it passes."""
    s = session.horizon.solver
    full = [session.act, *session.assumptions, *assumptions]
    t0 = time.perf_counter()
    try:
        if deadline is None:
            return s.solve(full)
        budget = 20_000
        while True:
            if time.perf_counter() >= deadline:
                raise Stopped
            ok = s.solve_limited(full, budget)
            if ok is not None:
                return ok
            budget *= 2
    finally:
        if session.stats:
            session.stats[-1].solve_s += time.perf_counter() - t0


def improve(state: Best, strategy: str = "linear", deadline: float | None = None) -> None:
    """Cheaper models at the session's horizon until ``state.best`` is proved (``state.lower
    == state.best``), or :class:`Stopped` or :class:`KeyboardInterrupt` ends the search
    (they propagate; ``state`` holds the best plan and the bound known until then)."""
    bound = state.bound
    while state.lower < state.best:
        k = state.best - 1 if strategy == "linear" else (state.lower + state.best - 1) // 2
        a = bound.at_most(k)
        if a is None:
            state.lower = k + 1
            continue
        state.solves += 1
        if solve_until(state.session, a, deadline):
            state.take(bound.model_value())
        else:
            state.lower = k + 1


def run_optimal(theory, query, objective: Objective, solutions: int = 1, solver: str = "glucose4",
                max_horizon: int | None = None, over_lengths: bool = False, time_limit: float | None = None,
                strategy: str = "linear", totalizer: bool = False, flat: bool = True,
                on_horizon: Callable[[HorizonStats], None] | None = None) -> OptimalResult:
    """The cheapest plan of a query: at its shortest length (lexicographic, the default), or
    over its whole maxstep range (``over_lengths``; an open range stops at ``max_horizon``),
    and with ``solutions`` other than 1 every plan of that cost (0 = all).  ``time_limit``
    (seconds) bounds the search for cheaper plans; Ctrl-C likewise stops it: the result then
    holds the best plan so far, ``proved`` false and the bound known."""
    t_end = None if time_limit is None else time.perf_counter() + time_limit
    if over_lengths:
        return _over_lengths(theory, query, objective, solutions, solver, max_horizon, t_end, strategy, totalizer,
                             flat, on_horizon)
    session = QuerySession(theory, query, solver, max_horizon, commit=True)
    failed = find_horizon(session, on_horizon)
    if session.found is None:
        status = PlanStatus.NO_PLAN if query.hi is not None else PlanStatus.HORIZON_LIMIT
        return OptimalResult(QueryResult(query.label, status, None, [], failed, session.stats,
                                         session.horizon.template_s), None)
    m = session.found
    bound = CostBound(session, objective, m, totalizer, flat)
    state = Best(session, bound)
    stopped = None
    try:
        improve(state, strategy, t_end)
    except Stopped:
        stopped = "time_limit"
    except KeyboardInterrupt:
        stopped = "interrupted"
    opt = Optimum(objective.text, state.best, stopped is None, state.lower, stopped=stopped,
                  solves=state.solves + 1)
    histories = [state.history]
    if solutions != 1 and stopped is None:
        histories = list(_every_plan(session, bound, state.best, solutions))
    base = QueryResult(query.label, PlanStatus.FOUND, m, histories, failed, session.stats,
                       session.horizon.template_s, solutions=solutions)
    return OptimalResult(base, opt)


class Best:
    """The best plan so far at one horizon, decoded when found (a later solve replaces the
    model), and the lower bound proved there."""

    def __init__(self, session: QuerySession, bound: CostBound) -> None:
        self.session = session
        self.bound = bound
        self.best = bound.model_value()
        self.history = decode_history(session)
        self.lower = bound.low
        self.solves = 0

    def take(self, value: int) -> None:
        self.best = value
        self.history = decode_history(self.session)


def _every_plan(session: QuerySession, bound: CostBound, value: int, solutions: int) -> Iterator[History]:
    """Every plan of cost ``value`` at the session's horizon (it must be the optimum)."""
    a = bound.at_most(value) or []
    session.assumptions.extend(a)
    try:
        if not solve_until(session, [], None):
            return
        n = 0
        while True:
            yield decode_history(session)
            n += 1
            if solutions and n >= solutions:
                return
            session.block_current()
            if not solve_until(session, [], None):
                return
    finally:
        del session.assumptions[len(session.assumptions) - len(a):]


def _over_lengths(theory, query, objective, solutions, solver, max_horizon, t_end, strategy, totalizer, flat,
                  on_horizon) -> OptimalResult:
    if query.hi is None and max_horizon is None:
        raise CPlusError(f"--over-lengths searches every length of the query's maxstep range, and query "
                         f"'{query.label}' has {query.lo}..infinity: give --max-horizon N")
    session = QuerySession(theory, query, solver, max_horizon, commit=False)
    failed: list[int] = []
    best: int | None = None
    best_hist: History | None = None
    plans: list[History] = []          # every plan of cost `best` so far (solutions != 1)
    found_at: int | None = None
    stopped = None
    solves = 0
    done: int | None = None            # every length up to here is searched
    base_assumptions = list(session.assumptions)
    low = None
    try:
        for m in session.horizons():
            # the time limit bounds the search for cheaper plans: the first plan is always waited for
            if best is not None and t_end is not None and time.perf_counter() >= t_end:
                raise Stopped
            session.horizon.extend_to(m, query.loc)
            bound = CostBound(session, objective, m, totalizer, flat)
            low = bound.low if low is None else min(low, bound.low)
            extra: list[int] = []
            if best is not None:
                a = bound.at_most(best if solutions != 1 else best - 1)
                if a is None:                 # nothing cheaper can exist at any length
                    done = m
                    break
                extra = a
            session.assumptions = base_assumptions + extra
            ok = _solve_at(session, m, t_end if best is not None else None)
            solves += 1
            session.assumptions = list(base_assumptions)
            if on_horizon:
                on_horizon(session.stats[-1])
            if not ok:
                if best is None:
                    failed.append(m)
                done = m
                continue
            state = Best(session, bound)
            try:
                improve(state, strategy, t_end)
            finally:
                solves += state.solves
                if best is None or state.best < best:
                    best, best_hist, found_at, plans = state.best, state.history, m, []
            v = state.best
            if solutions != 1 and best == v:
                plans.extend(_every_plan(session, bound, v, solutions))
            done = m
    except Stopped:
        stopped = "time_limit"
    except KeyboardInterrupt:
        if best is None:
            raise
        stopped = "interrupted"
    if best is None:
        status = PlanStatus.NO_PLAN if query.hi is not None else PlanStatus.HORIZON_LIMIT
        if stopped:
            status = PlanStatus.HORIZON_LIMIT
        return OptimalResult(QueryResult(query.label, status, None, [], failed, session.stats,
                                         session.horizon.template_s), None)
    assert best_hist is not None and found_at is not None
    proved = stopped is None
    histories = plans if solutions != 1 and proved else [best_hist]
    if solutions:
        histories = histories[:solutions]
    opt = Optimum(objective.text, best, proved, best if proved else (low if low is not None else best),
                  over_lengths=True, proved_up_to=done, stopped=stopped, solves=solves)
    base = QueryResult(query.label, PlanStatus.FOUND, found_at, histories, failed, session.stats,
                       session.horizon.template_s, solutions=solutions)
    return OptimalResult(base, opt)


def _solve_at(session: QuerySession, m: int, t_end: float | None) -> bool:
    """:meth:`QuerySession.solve_at` (for a session that never commits) whose solve keeps to
    the deadline."""
    t0 = time.perf_counter()
    h = session.horizon
    if session.act is not None:
        h.solver.add_clause([-session.act])
    session.out_of_range = []
    h.extend_to(m, session.query.loc)
    session._add_items(m)
    session._projection = None
    session.stats.append(HorizonStats(m, h.top, h.solver.count, time.perf_counter() - t0, 0.0))
    ok = solve_until(session, [], t_end)
    session.stats[-1].satisfiable = ok
    session.stats[-1].models = int(ok)
    return ok


# ---------------------------------------------------------------------------- output

def optimum_text(result: OptimalResult) -> str:
    """The line after a result's plans: ``cost = 7 (optimal)``, or what is known."""
    if result.optimum is None:
        return ""
    return line(result.optimum, result.stats[0].maxstep if result.stats else 0)


def line(opt: Optimum, first: int | None) -> str:
    """``term = value (what is proved)`` and a blank line; ``first``: the query's first
    maxstep (for ``--over-lengths``)."""
    if opt.proved:
        how = f"optimal over maxstep {first}..{opt.proved_up_to}" if opt.over_lengths else "optimal"
    else:
        why = {"time_limit": "--time-limit", "max_iterations": "--max-iterations"}.get(opt.stopped or "",
                                                                                   "interrupted")
        how = f"not proved optimal ({why}): lower bound {opt.lower_bound}"
        if opt.over_lengths and opt.proved_up_to is not None:
            how += f", every length up to maxstep {opt.proved_up_to} searched"
    return f"{opt.term} = {opt.value} ({how})\n\n"


def optimum_json(result: OptimalResult) -> dict | None:
    return None if result.optimum is None else optimum_fields(result.optimum)


def optimum_fields(opt: Optimum) -> dict:
    """An optimum as the ``"optimum"`` of a ``cplus.plan/1`` result."""
    return {"term": opt.term, "value": opt.value, "proved": opt.proved, "lower_bound": opt.lower_bound,
            "over_lengths": opt.over_lengths, "proved_up_to": opt.proved_up_to, "stopped": opt.stopped}
