"""One live solver per query, extended one step at a time.

Solver variables are allocated in blocks: the rigid atoms first, then for each step t a
block of N variables (every non-rigid atom at t), then the auxiliary variables of each
template instance, and the query's own variables where they are needed.  Step m+1 only
*adds* clauses (the transition template instantiated for m -> m+1); whatever depends on the
current maxstep (the goal, conditions with ``maxstep``, quantifiers over steps) is guarded
by an activation literal per horizon, so learned clauses survive from one horizon to the
next and across refinement iterations.
"""
from __future__ import annotations

import operator
import time
from collections.abc import Callable, Iterator
from itertools import repeat
from typing import TypeVar

from cplus import ir
from cplus.errors import GroundingError, Location, OutOfMemoryError
from cplus.ground.compile import Ctx, bind, compile_formula
from cplus.ground.pf import PF, mk_and, mk_or, neg
from cplus.ground.restrict import fixed_at_zero, has_step_var
from cplus.ground.theory import GroundTheory
from cplus.limits import MAX_SOLVER_VARS, clause_bytes, count, memory_budget, out_of_memory, too_large
from cplus.program import QuerySpec
from cplus.record import Record
from cplus.sat.cnf import ClauseBuilder
from cplus.sat.reach import unreachable
from cplus.sat.solver import DEFAULT_SOLVER, SatSolver
from cplus.sat.templates import Layout, Template, build_templates

__all__ = ["Horizon", "QuerySession", "HorizonStats"]

_T = TypeVar("_T")


class HorizonStats(Record):
    _fields = ("maxstep", "variables", "clauses", "encode_s", "solve_s", "satisfiable", "models")

    maxstep: int
    variables: int
    clauses: int
    encode_s: float
    solve_s: float
    satisfiable: bool | None
    models: int

    def __init__(
            self,
            maxstep: int,
            variables: int,
            clauses: int,
            encode_s: float,
            solve_s: float,
            satisfiable: bool | None = None,
            models: int = 0) -> None:
        self.maxstep = maxstep
        self.variables = variables
        self.clauses = clauses
        self.encode_s = encode_s
        self.solve_s = solve_s
        self.satisfiable = satisfiable
        self.models = models


class Horizon:
    """The clauses of D_m for growing m in one incremental solver."""

    def __init__(self, theory: GroundTheory, solver: str = DEFAULT_SOLVER, solver_factory=SatSolver,
                 templates: tuple[Layout, Template, Template, Template] | None = None,
                 fixed: set[int] | None = None) -> None:
        """``templates``: the result of :func:`build_templates` for ``theory``, when the caller
        keeps it for several solvers (the online loop makes one per re-plan).  Otherwise they
        are built here, and ``fixed`` (positive atoms that hold at step 0 in every history
        wanted: a query's initial state) leaves out fluent values unreachable from them."""
        t0 = time.perf_counter()
        self.theory = theory
        if templates is None:
            templates = build_templates(theory, _dead(theory, fixed))
        self.layout, self.t_rigid, self.t_init, self.t_trans = templates
        self.template_s = time.perf_counter() - t0
        self.solver = solver_factory(solver)
        L = self.layout
        self.top = L.R
        self.blocks: list[int] = []
        self._rigid_range = range(1, L.R + 1)
        self.m = -1
        self.extra: list[PF] = []          # transition constraints added later (refinement)
        self.step_hooks: list[Callable[[int], None]] = []   # see each_step
        self.builder = ClauseBuilder(self.new_var, self.solver.add_clause)
        self._instantiate(self.t_rigid, 0, 0)
        self._add_block()
        self._instantiate(self.t_init, self.blocks[0], self.blocks[0])
        self.m = 0

    # ------------------------------------------------------------------ variables
    def new_var(self) -> int:
        self.top += 1
        return self.top

    def _add_block(self) -> None:
        self.blocks.append(self.top + 1)
        self.top += self.layout.N

    def var(self, aid: int, t: int | None) -> int:
        """Solver variable of an atom at step t (rigid atoms: t is ignored)."""
        L = self.layout
        r = L.ridx.get(aid)
        if r is not None:
            return r + 1
        return self.blocks[t] + L.pos[aid]  # type: ignore[index]

    # ------------------------------------------------------------------ templates
    def _instantiate(self, tpl: Template, b0: int, b1: int) -> None:
        L = self.layout
        n_aux = tpl.top - L.base_top
        aux = self.top + 1
        self.top += n_aux
        off = [0]
        off.extend(self._rigid_range)
        off.extend(range(b0, b0 + L.N))
        off.extend(range(b1, b1 + L.N))
        off.extend(range(aux, aux + n_aux))
        for part, slot in tpl.extra:
            b = b1 if slot == 1 else b0
            self._instantiate(part, b, b)
        # literal x of the template is entry x of a signed table (-x counts from its end): one
        # C-level lookup per literal, a map object per clause that the solver reads itself, and
        # no Python frame per clause (bw-20-random's 10 steps: 0.13 s instead of 0.17 with a
        # generator; numpy's renaming of every literal at once plus a slice per clause was no faster)
        off.extend(map(operator.neg, off[:0:-1]))
        self.solver.add_clauses(map(map, repeat(off.__getitem__), tpl.clauses))

    def extend_to(self, m: int, loc: Location | None = None) -> None:
        """Add transitions until the horizon is m (refused at once, located at ``loc``, when
        the clauses of horizon m cannot fit in memory)."""
        if m > self.m:
            self._check_size(m, loc)
        while self.m < m:
            t = self.m
            self._add_block()
            self._instantiate(self.t_trans, self.blocks[t], self.blocks[t + 1])
            for f in self.extra:
                self.builder.add(self._at(f, t))
            self.m += 1
            for hook in self.step_hooks:
                hook(self.m)

    def _check_size(self, m: int, loc: Location | None) -> None:
        steps = m - self.m
        n, literals, aux = self.t_trans.size(self.layout.base_top)
        per_var = self.layout.N + aux
        need = steps * (clause_bytes(n, literals) + 64 * per_var)
        if need > memory_budget():
            raise GroundingError(too_large(f"maxstep {count(m)} means {count(steps * n)} clauses "
                                           f"({count(n)} per step)", need), loc)
        if self.top + steps * per_var > MAX_SOLVER_VARS:
            raise GroundingError(f"maxstep {count(m)} means {count(self.top + steps * per_var)} solver variables, "
                                 f"more than the solver's limit of {count(MAX_SOLVER_VARS)}", loc)

    def _at(self, f: PF, t: int) -> PF:
        """A transition formula over template codes, placed at transition t."""
        from cplus.ground.pf import map_lits

        def place(code: int) -> int:
            aid, slot = divmod(code - 1, 3)
            return self.var(aid, None if slot == 2 else t + slot)
        return map_lits(f, place)

    def each_step(self, hook: Callable[[int], None]) -> None:
        """Call ``hook(t)`` for every step ``t`` of the horizon: now for 0..m, later for each
        new step once its clauses are in.  The hook may allocate variables (:meth:`new_var`)
        and add clauses over any step up to ``t`` (:meth:`var`): the way to constrain every
        step, present and future, with clauses that are not transition formulas (nogoods over
        several steps, auxiliary variables per step)."""
        self.step_hooks.append(hook)
        for t in range(self.m + 1):
            hook(t)

    def forbid_everywhere(self, f: PF) -> None:
        """Add ``not f`` (a transition formula over template codes) at every transition,
        existing and future ones."""
        from cplus.ground.pf import neg
        g = neg(f)
        self.extra.append(g)
        for t in range(self.m):
            self.builder.add(self._at(g, t))


def _dead(theory: GroundTheory, fixed: set[int] | None) -> frozenset[int] | set[int]:
    """The fluent values to leave out of the templates, given the atoms fixed at step 0."""
    if theory.initial is not None:      # ground for one initial state: it must be this one
        if fixed is None or theory.initial != frozenset(fixed):
            raise ValueError("this theory was ground for another initial state (see GroundTheory.initial)")
        return theory.dead
    return unreachable(theory, fixed) if fixed else set()


_COMMIT_FACTOR = 8
"""Propagations per clause in the solver that a horizon may take under its assumption before
its goal is committed to (see :class:`QuerySession`)."""


class QuerySession:
    """Answer one query: horizons in ascending order, then models at the first good one.

    With ``commit`` (the planner's own searches) a horizon that takes long is committed to:
    a solver finds a model much faster when the goal is a unit clause than when it is
    assumed (bw-25's plan at horizon 9: 0.8 s instead of 2.0, medians over clause orders),
    and proofs that there is none take about as long either way.  The price of committing
    to a horizon without a history is a new solver for the next one (the templates are
    kept), so the budget grows with the clauses a new solver takes, and doubles after each
    such miss.  Sessions with hooks, later constraints or assumptions never commit."""

    def __init__(self, theory: GroundTheory, query: QuerySpec, solver: str = DEFAULT_SOLVER,
                 max_horizon: int | None = None, solver_factory=SatSolver,
                 templates: tuple[Layout, Template, Template, Template] | None = None,
                 commit: bool = False) -> None:
        self.commit = commit
        self._commit_factor = _COMMIT_FACTOR
        self._stale = False
        self._last = 0                      # propagations of the last horizon's solve
        self._solver_name = solver
        self._solver_factory = solver_factory
        self.theory = theory
        self.query = query
        self.max_horizon = max_horizon
        self.sig = theory.sig
        self.atoms = theory.atoms
        self.ctx = Ctx(self.sig, self.atoms, self._mklit)
        self.items = []
        for formula, loc in query.items:
            dynamic = ir.mentions(formula, (ir.MaxStepT,)) or has_step_var(formula)
            self.items.append([formula, loc, compile_formula(formula, self.ctx), dynamic, False])
        self.rules = [(None if head is None else compile_formula(head, self.ctx), compile_formula(body, self.ctx),
                       ir.free_vars(ir.conj((body,) if head is None else (head, body))), loc)
                      for head, body, loc in query.rules or ()]
        # the rules of the theory's time-stamped facts (see _ground_facts)
        self.facts = []
        for rule in getattr(theory.program, "facts", ()):
            aux = None if rule.cst is None else ir.Atom(rule.cst, ir.Lit("true"), rule.loc)
            variables = ir.free_vars(rule.body if aux is None else ir.conj((aux, rule.body)))
            self.facts.append((rule, variables, None if aux is None else compile_formula(aux, self.ctx),
                               compile_formula(rule.body, self.ctx)))
        self.facts_apply = True     # False: no stamped rule applies (a proof's states are any states)
        self.horizon = self._located(lambda: Horizon(theory, solver, solver_factory, templates,
                                                     None if templates is not None else self._fixed_at_zero()),
                                     "encoding this query")
        self.stats: list[HorizonStats] = []
        self.assumptions: list[int] = []   # assumed at every solve, besides the horizon's own
        self.act: int | None = None
        self.found: int | None = None
        self.out_of_range: list = []
        self._projection: list[tuple[int, int | None]] | None = None

    def _located(self, work: Callable[[], _T], doing: str) -> _T:
        """``work()``, with a grounding error that names no place of its own located at the
        query, and a :class:`MemoryError` (the address-space limit reached while encoding or
        solving) reported as ``doing`` being too large."""
        try:
            return work()
        except GroundingError as exc:
            if exc.loc is None:
                exc.loc = self.query.loc
            raise
        except MemoryError:
            pass        # the exception, and what the frames it holds built, are released here
        raise OutOfMemoryError(out_of_memory(doing), self.query.loc)

    # ------------------------------------------------------------------ query items
    def _fixed_at_zero(self) -> set[int]:
        return fixed_at_zero(self.sig, self.atoms, self.query)

    def _mklit(self, aid: int, t: object) -> PF:
        a = aid if aid > 0 else -aid
        gc = self.atoms.gc_of[a]
        h = self.horizon
        if gc.decl.kind == "rigid":  # type: ignore[union-attr]
            v = h.var(a, None)
        else:
            if t is None:
                raise GroundingError(f"'{gc.text}' needs a time stamp in a query (write 'i: {gc.text}')")  # type: ignore
            last = self._m - 1 if gc.decl.is_action else self._m  # type: ignore[union-attr]
            if not (0 <= t <= last):  # type: ignore[operator]
                self._oor = True
                return False
            v = h.var(a, t)  # type: ignore[arg-type]
        return v if aid > 0 else -v

    def _ground_item(self, item, m: int) -> tuple[PF, bool]:
        formula, loc, fn, _, _ = item
        self._m = m
        self._oor = False
        parts: list[PF] = []
        variables = ir.free_vars(formula)

        def leaf(env: dict) -> None:
            parts.append(fn(env, None))
        self._bind(variables, leaf, loc, m)
        return mk_and(parts), self._oor

    def _bind(self, variables, leaf, loc, m: int) -> None:
        """Every instance of ``variables`` at horizon m, a grounding error located at ``loc``
        when it names no place of its own."""
        try:
            bind(self.sig, variables, [], leaf, {"$maxstep": m})
        except GroundingError as exc:
            if exc.loc is None:
                exc.loc = loc
            raise

    def _ground_facts(self, m: int) -> PF:
        """The rules of the theory's time-stamped facts at horizon m (:class:`~cplus.program.StampedRule`):
        each instance's hidden fluent is its body at the rule's step and false at the others
        (every step, when the step lies beyond m: CCALC grounds no rule at a step that does not
        exist); a body atom stamped outside 0..m is false.  A rule with head false forbids its
        body."""
        parts: list[PF] = []
        self._m = m
        apply = self.facts_apply
        for rule, variables, aux_fn, body_fn in self.facts:
            def leaf(env: dict, rule=rule, aux_fn=aux_fn, body_fn=body_fn) -> None:
                if aux_fn is None:
                    if apply:
                        parts.append(neg(body_fn(env, None)))
                    return
                for t in range(m + 1):
                    aux = aux_fn(env, t)
                    if t == rule.step and apply:
                        body = body_fn(env, None)
                        parts.append(mk_and([mk_or([neg(aux), body]), mk_or([aux, neg(body)])]))
                    else:
                        parts.append(neg(aux))
            self._bind(variables, leaf, rule.loc, m)
        return mk_and(parts)

    def _add_items(self, m: int) -> None:
        h = self.horizon
        self.act = h.new_var()
        if self.facts:      # they name steps, and the steps grow with the horizon: guarded
            h.builder.add(self._ground_facts(m), guard=self.act)
        if self.query.nm:
            self._add_completion(m)
        for item in self.items:
            if item[4]:
                continue
            pf, oor = self._ground_item(item, m)
            if item[3] or oor:
                h.builder.add(pf, guard=self.act)
                if oor:
                    self.out_of_range.append(item[1])
            else:
                h.builder.add(pf)
                item[4] = True

    def _add_completion(self, m: int) -> None:
        """An nmquery at horizon m, as CCALC answers it: its ground rules are literally
        completed on their own, over every atom of the history (``a <-> B1 | ... | Bk`` for
        the bodies of its rules with head ``a``, the literal ``-p`` of a Boolean ``p`` too, so
        an atom no rule causes is false), and the histories satisfy both this completion and
        the domain's.  Rules whose head lies outside 0..m have no atom there and are left out.
        Constants internal to the encoding have no name an nmquery could cause, and are left
        to the domain's completion."""
        h = self.horizon
        act = self.act
        assert act is not None
        bodies: dict[int, list[PF]] = {}
        for head_fn, body_fn, variables, loc in self.rules:
            def leaf(env: dict, head_fn=head_fn, body_fn=body_fn) -> None:
                self._oor = False
                head = True if head_fn is None else head_fn(env, None)
                out = self._oor
                body = body_fn(env, None)
                if head_fn is None:
                    h.builder.add(neg(body), guard=act)       # caused false if body
                elif type(head) is int and not out:
                    bodies.setdefault(head, []).append(body)
            self._m = m
            self._bind(variables, leaf, loc, m)
        for gc in self.sig.ground:
            d = gc.decl
            if d.hidden:
                continue
            pairs = self.atoms.head_lits(gc)
            if len(pairs) < 2:
                continue
            steps: list[int | None] = [None] if d.kind == "rigid" else list(range(m if d.is_action else m + 1))
            for t in steps:
                for aid, _ in pairs:
                    if aid < 0 and not gc.boolean:
                        continue
                    v = h.var(abs(aid), t) * (1 if aid > 0 else -1)
                    f = mk_or(bodies.get(v, ()))
                    h.builder.add(mk_and([mk_or([-v, f]), mk_or([v, neg(f)])]), guard=act)

    def assert_items(self, m: int) -> None:
        """Add every query condition at horizon m unconditionally (for a fixed horizon), and
        the theory's time-stamped facts."""
        if self.facts:
            self.horizon.builder.add(self._ground_facts(m))
        for item in self.items:
            pf, _ = self._ground_item(item, m)
            self.horizon.builder.add(pf)

    # ------------------------------------------------------------------ search
    def horizons(self) -> Iterator[int]:
        q = self.query
        hi = q.hi if q.hi is not None else self.max_horizon
        m = q.lo
        while hi is None or m <= hi:
            yield m
            m += 1

    def solve_at(self, m: int) -> bool:
        """Extend to horizon m (only upwards) and solve; records statistics."""
        t0 = time.perf_counter()
        self.open_horizon(m)
        h = self.horizon
        t1 = time.perf_counter()
        ok = self._located(lambda: self._solve(h), f"solving this query at maxstep {m}")
        t2 = time.perf_counter()
        self.stats.append(HorizonStats(m, h.top, h.solver.count, t1 - t0, t2 - t1, ok, 1 if ok else 0))
        return ok

    def open_horizon(self, m: int) -> None:
        """Extend to horizon m (only upwards) and put its goal behind :attr:`act`, without
        solving: for callers that solve in slices (:mod:`cplus.parallel`)."""
        self._located(lambda: self._open(m), f"encoding this query at maxstep {m}")

    def _open(self, m: int) -> None:
        if self._stale:
            self._renew()
        h = self.horizon
        if self.act is not None:
            h.solver.add_clause([-self.act])    # retire the previous horizon's goal
        self.out_of_range = []
        h.extend_to(m, self.query.loc)
        self._add_items(m)
        self._projection = None

    def _solve(self, h: Horizon) -> bool:
        s = h.solver
        assumptions = [self.act, *self.assumptions]
        if not self.commit or self.assumptions or h.step_hooks or h.extra:
            return s.solve(assumptions)
        before = s.propagations
        # a horizon much slower than the one before: proofs of no history grow step by step,
        # a history is found in one jump (and a new solver would lose what was learned)
        budget = max(self._commit_factor * max(s.count, 1), 4 * self._last)
        ok = s.solve_limited(assumptions, budget)
        if ok is None:
            s.add_clause([self.act])        # committed: this horizon's goal holds from now on
            ok = s.solve(assumptions)
            if not ok:                       # no model any more: the next horizon needs a new solver
                self._stale = True
                self._commit_factor *= 4
        self._last = s.propagations - before
        return ok

    def _renew(self) -> None:
        """A new solver with the same templates, after a horizon without history was
        committed to (the items are added again at the next horizon)."""
        old = self.horizon
        self.horizon = Horizon(self.theory, self._solver_name, self._solver_factory,
                               (old.layout, old.t_rigid, old.t_init, old.t_trans))
        self.horizon.template_s = old.template_s
        old.solver.delete()
        self.act = None
        for item in self.items:
            item[4] = False
        self._stale = False
        self._last = 0

    def resolve(self) -> bool:
        """Solve again at the current horizon (after clauses were added)."""
        h = self.horizon
        t0 = time.perf_counter()
        ok = self._located(lambda: h.solver.solve([self.act, *self.assumptions]),
                           f"solving this query at maxstep {h.m}")
        st = self.stats[-1]
        st.solve_s += time.perf_counter() - t0
        st.satisfiable = ok
        return ok

    def block_current(self) -> None:
        """Exclude the history of the current model (only at this horizon)."""
        h = self.horizon
        s = h.solver
        clause = [-self.act]  # type: ignore[operator]
        for v in self.projection_vars():
            clause.append(-v if s.value(v) else v)
        s.add_clause(clause)

    def projection_vars(self) -> list[int]:
        """Solver variables of the history atoms: fluents 0..m, actions 0..m-1, rigids.
        For a non-Boolean constant one atom per value is listed (exactly one is true)."""
        if self._projection is None:
            h = self.horizon
            m = h.m
            out: list[int] = []
            for aid in h.layout.rigid_atoms:
                if not self.atoms.gc_of[aid].decl.hidden:  # type: ignore[union-attr]
                    out.append(h.var(aid, None))
            for aid in h.layout.step_atoms:
                gc = self.atoms.gc_of[aid]
                if gc.decl.hidden:  # type: ignore[union-attr]
                    continue
                last = m - 1 if gc.decl.is_action else m  # type: ignore[union-attr]
                out.extend(h.var(aid, t) for t in range(last + 1))
            self._projection = out  # type: ignore[assignment]
        return self._projection  # type: ignore[return-value]
