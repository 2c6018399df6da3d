"""Grounding restricted to the fluent values reachable from a query's initial state.

The templates are the same for every step, so they hold every value of every fluent; an ASP
grounder instead builds only what can be derived from the initial state.  Three water tanks
of 200, 125 and 75 litres poured into each other from 200/0/0 only ever hold 19 of their
603 levels, and grounding their pouring laws over every pair of levels makes 324,000 rules
of which the templates keep a few hundred.

Reachability (:class:`Reachability`): starting from the values the query fixes at step 0
(and every value of a fluent it leaves free, C.3), a value of a non-Boolean fluent becomes
*possible* when some static or dynamic rule with that head has a body whose positive
top-level atoms are all possible (for a self-supporting rule, its rest: inertia keeps what
was possible, ``exogenous`` makes everything possible).  Rules are completed, not
minimised, so values that a step's own laws support in a loop (``caused f=1 if g=1`` and
``caused g=1 if f=1``) hold together with no chain from the start: every value of a fluent on
such a loop (:func:`cyclic_fluents`) is possible from the outset.  This over-approximates
the values taken at *any* step, so the others are false in every history.

Restricted grounding (:func:`ground_reachable`) interleaves the two, as a semi-naive
bottom-up grounder does: a law's positive body atoms ``c(args) = V`` over such fluents are
*generators* that bind their variables from the possible values only (a join on the atoms,
not a loop over the domains), and each round binds only what involves a value that became
possible in the last round.  Laws that cannot make a value possible (constraints, action
laws, negative heads) are ground once at the end.  The rules are exactly those of the full
grounding that the templates keep (the same bodies; only their order differs), and
:attr:`GroundTheory.dead` is exactly :func:`cplus.sat.reach.unreachable` of the full theory.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

from cplus import ir, limits
from cplus.errors import GroundingError
from cplus.ground.compile import Ctx, bind, binding_levels, compile_formula, domain_of, level_solvers, too_many_tries
from cplus.ground.cost import options_of, passing
from cplus.ground.pf import PF, mk_and
from cplus.ground.vector import ground_vectorized, matching
from cplus.signature import SIMPLE_KINDS, ConstDecl, StepSort

__all__ = ["Reachability", "ground_reachable", "fixed_at_zero", "has_step_var", "cyclic_fluents"]


class Reachability:
    """The least set of possible fluent values, computed incrementally as rules arrive.

    ``closed`` holds the candidate atoms (values of non-Boolean, non-additive fluents) not
    possible yet; :meth:`add_rules` takes ``(head code, body)`` pairs of static and dynamic
    rules; :meth:`take_fresh` hands out the atoms that became possible since its last call.
    """

    def __init__(self, sig, atoms, fixed: Iterable[int], laws: Iterable = ()) -> None:
        """``laws``: the program's laws, whose same-step cycles make values possible without
        a start (:func:`cyclic_fluents`)."""
        fixed = set(fixed)
        self.atoms = atoms
        candidates: set[int] = set()
        possible: set[int] = set()
        cyclic = cyclic_fluents(laws, _candidate_decls(sig))
        for gc in sig.ground:
            d = gc.decl
            if gc.boolean or not d.is_fluent or d.kind == "additiveFluent":
                continue
            ids = atoms.atoms(gc)
            candidates.update(ids)
            pinned = [a for a in ids if a in fixed]
            if id(d) in cyclic:              # may support itself at any step
                possible.update(ids)
            elif pinned:
                possible.update(pinned)
            elif d.kind in SIMPLE_KINDS:     # free at step 0 (C.3)
                possible.update(ids)
        self.candidates = candidates
        self.closed = candidates - possible
        self._fresh = sorted(possible)
        self._watch: dict[int, list[int]] = {}
        self._heads: list[int] = []
        self._missing: list[int] = []

    @property
    def trivial(self) -> bool:
        """Whether every candidate value is possible already (nothing can be pruned)."""
        return not self.closed

    def add_rules(self, rules: Iterable[tuple[int, PF]]) -> None:
        closed = self.closed
        watch, heads, missing = self._watch, self._heads, self._missing
        for code, body in rules:
            if code < 0:
                continue
            head = (code - 1) // 3
            if head not in closed:
                continue
            items = body[1] if type(body) is tuple and body[0] == "&" else (body,)
            need = [a for a in [(g - 1) // 3 for g in items if type(g) is int and g > 0 and g != code]
                    if a in closed]
            if not need:
                self._open(head)
                continue
            if len(need) > 1:
                need = list(set(need))
            i = len(heads)
            heads.append(head)
            missing.append(len(need))
            for a in need:
                w = watch.get(a)
                if w is None:
                    watch[a] = [i]
                else:
                    w.append(i)

    def _open(self, a: int) -> None:
        closed, watch, heads, missing = self.closed, self._watch, self._heads, self._missing
        closed.discard(a)
        self._fresh.append(a)
        queue = [a]
        while queue:
            for i in watch.pop(queue.pop(), ()):
                missing[i] -= 1
                if missing[i] == 0 and heads[i] in closed:
                    closed.discard(heads[i])
                    self._fresh.append(heads[i])
                    queue.append(heads[i])

    def take_fresh(self) -> list[int]:
        out, self._fresh = self._fresh, []
        return out


def _candidate_decls(sig) -> dict[int, ConstDecl]:
    """The declarations whose values :class:`Reachability` may prune, by id."""
    return {id(gc.decl): gc.decl for gc in sig.ground
            if not gc.boolean and gc.decl.is_fluent and gc.decl.kind != "additiveFluent"}


def _shape(node: object) -> object:
    """A term or atom without its locations, to compare two occurrences."""
    if isinstance(node, ConstDecl):
        return id(node)
    if isinstance(node, tuple):
        fields = getattr(node, "_fields", None)
        if fields is not None:
            return (type(node).__name__, *(_shape(getattr(node, f)) for f in fields if f != "loc"))
        return tuple(_shape(x) for x in node)
    return node


def cyclic_fluents(laws: Iterable, candidates: dict[int, ConstDecl]) -> set[int]:
    """Ids of the declarations among ``candidates`` that lie on a cycle of same-step support.

    Causal rules are completed, not minimised: ``caused f=1 if g=1`` with ``caused g=1 if
    f=1`` (both statically determined) has a history where f=g=1 supports itself, though no
    chain of rules from the start leads there.  Values a step's own laws can support in a
    loop are therefore possible whatever the start: a law whose head value is a value of
    ``c`` and whose body (at the head's step: a static law's, a dynamic law's ``if`` part)
    has a positive atom of ``d`` is an edge c -> d, and every declaration on a cycle of such
    edges counts.  An atom that is literally the law's head (``caused c=V if c=V``, the
    frames) supports only itself, which :class:`Reachability` allows for already."""
    if not candidates:
        return set()
    edges: dict[int, set[int]] = {}
    for law in laws:
        if law.cls not in ("static", "dynamic"):
            continue
        if law.frame is not None:          # one rule c=v if c=v & body per value v of c
            if law.frame == "rigid" or law.frame_cst is None:
                continue
            heads: list = [law.frame_cst]
            own = {_shape(law.frame_cst)}
        else:
            heads = [h.cst for h in ir.conjuncts(law.head) if isinstance(h, ir.Atom)]
            own = {_shape(h) for h in ir.conjuncts(law.head) if isinstance(h, ir.Atom)}
        head_ids = _decls(heads, candidates)
        if not head_ids:
            continue
        # what a ground body may need at the head's step: the constants of every conjunct but
        # a negated atom and the head itself, and those inside the head's arguments and value
        needs: list = []
        for h in heads:
            for t in (h.args if isinstance(h, ir.Cst) else ()):
                ir.constants_in(t, needs)
        for h in ir.conjuncts(law.head):
            if isinstance(h, ir.Atom):
                ir.constants_in(h.value, needs)
        for c in ir.conjuncts(law.body):
            if isinstance(c, ir.Not) and isinstance(c.arg, ir.Atom):
                continue
            if isinstance(c, ir.Atom) and _shape(c.cst if law.frame is not None else c) in own:
                ir.constants_in(c.value, needs)
                for t in (c.cst.args if isinstance(c.cst, ir.Cst) else ()):
                    ir.constants_in(t, needs)
                continue
            ir.constants_in(c, needs)
        body_ids = _decls(needs, candidates)
        for h in head_ids:
            edges.setdefault(h, set()).update(body_ids)
    return _on_cycles(edges)


def _decls(csts: list, candidates: dict[int, ConstDecl]) -> set[int]:
    """The candidate declarations of constant occurrences (all of them for a variable)."""
    out: set[int] = set()
    for c in csts:
        if isinstance(c, ir.Cst):
            if id(c.decl) in candidates:
                out.add(id(c.decl))
        else:
            out.update(candidates)
    return out


def _on_cycles(edges: dict[int, set[int]]) -> set[int]:
    """The nodes of a directed graph that lie on a cycle (Tarjan's strongly connected
    components, iteratively)."""
    index: dict[int, int] = {}
    low: dict[int, int] = {}
    stack: list[int] = []
    on_stack: set[int] = set()
    out: set[int] = set()
    for root in edges:
        if root in index:
            continue
        work = [(root, iter(edges.get(root, ())))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(edges.get(w, ()))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    u = work[-1][0]
                    low[u] = min(low[u], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1 or v in edges.get(v, ()):
                        out.update(comp)
    return out


# --------------------------------------------------------------------------- the grounder


class _Gen:
    """A positive body atom ``c(args) = value`` that binds its variables from possible atoms:
    ``pattern`` has ``(True, name)`` for a variable and ``(False, object)`` for an object,
    the arguments first and the value last."""

    __slots__ = ("node", "decl", "pattern")

    def __init__(self, node: ir.Atom, decl: ConstDecl, pattern: tuple) -> None:
        self.node = node
        self.decl = decl
        self.pattern = pattern


def _generators(law, restrictable: set) -> list[_Gen]:
    head_decls = set()
    for h in ir.conjuncts(law.head):
        a = h.arg if isinstance(h, ir.Not) else h
        if isinstance(a, ir.Atom) and isinstance(a.cst, ir.Cst):
            head_decls.add(id(a.cst.decl))
    head_slot = 1 if law.cls == "dynamic" else 0
    gens = []
    for formula, slot in ((law.body, head_slot), (law.after, 0)):
        for c in ir.conjuncts(formula):
            if not (isinstance(c, ir.Atom) and isinstance(c.cst, ir.Cst) and id(c.cst.decl) in restrictable):
                continue
            terms = (*c.cst.args, c.value)
            if not all(isinstance(t, (ir.Var, ir.Lit)) for t in terms):
                continue
            if slot == head_slot and id(c.cst.decl) in head_decls:
                continue    # it may be the head itself (a self-supporting rule): not a need
            gens.append(_Gen(c, c.cst.decl, tuple((True, t.name) if isinstance(t, ir.Var)
                                               else (False, t.value)  # type: ignore[union-attr]
                                               for t in terms)))
    return gens


def _feeds(law) -> bool:
    """Whether the law's rules can make a fluent value possible (a positive head atom of a
    fluent, in a static or dynamic law)."""
    if law.cls not in ("static", "dynamic"):
        return False
    for h in ir.conjuncts(law.head):
        if isinstance(h, ir.Atom) and (isinstance(h.cst, ir.Var) or h.cst.decl.is_fluent):
            return True
    return False


def ground_reachable(g, fixed: set[int]) -> frozenset[int]:
    """Ground the laws of ``g`` (a :class:`~cplus.ground.theory._Grounder`) restricted to what
    is reachable from the positive atoms ``fixed`` at step 0; returns the unreachable values."""
    th = g.theory
    atoms = g.atoms
    reach = Reachability(g.sig, atoms, fixed, g.program.laws)
    if reach.trivial:
        for law in g.program.laws:
            g._law(law)
        return frozenset()
    instances: dict[int, list] = {}
    for gc in g.sig.ground:
        instances.setdefault(id(gc.decl), []).append(gc)
    restrictable = {k for k, gcs in instances.items()      # every instance's values are candidates
                    if all(not gc.boolean and all(a in reach.candidates for a in atoms.atoms(gc)) for gc in gcs)}
    feeding: list = []
    deferred: list = []
    for law in g.program.laws:
        gens = _generators(law, restrictable) if law.frame is None else []
        if not gens:
            g._law(law)          # every instance, as usual (frames: one rule per value)
            continue
        prep = g.prepare(law)
        if prep is not None:
            doms = {n: set(domain_of(g.sig, v, {})) for n, v in prep.variables.items()}
            (feeding if _feeds(law) else deferred).append((prep, gens, doms))
    marks = {"static": 0, "dynamic": 0}

    def scan() -> None:
        for cls in marks:
            rules = th.rules[cls]
            if len(rules) > marks[cls]:
                reach.add_rules(rules[marks[cls]:])
                marks[cls] = len(rules)
    scan()
    gc_of, value_of = atoms.gc_of, atoms.value_of
    old: dict[int, list] = {}        # declaration -> (args, value) of the atoms possible before
    while True:
        fresh = reach.take_fresh()
        if not fresh:
            break
        delta: dict[int, list] = {}
        for a in fresh:
            gc = gc_of[a]
            delta.setdefault(id(gc.decl), []).append((gc.args, value_of[a]))
        new = {k: old.get(k, []) + delta.get(k, []) for k in old.keys() | delta.keys()}
        for prep, gens, doms in feeding:
            n = len(gens)
            for i in range(n):
                pools = [old.get(id(gens[j].decl), ()) if j < i else
                         delta.get(id(gens[j].decl), ()) if j == i else
                         new.get(id(gens[j].decl), ()) for j in range(n)]
                if all(pools):
                    _bind_joined(g, prep, gens, doms, pools, i)
        scan()
        old = new
    for prep, gens, doms in deferred:
        pools = [old.get(id(gen.decl), ()) for gen in gens]
        if all(pools):
            _bind_joined(g, prep, gens, doms, pools, 0)
    return frozenset(reach.closed)


def _bind_joined(g, prep, gens: list[_Gen], doms: dict[str, set], pools: list, first: int) -> None:
    """Call ``prep.leaf(env)`` for every binding of the law whose generator atoms come from
    ``pools`` (lists of ``(args, value)``) and that passes its filters.  ``doms``: the values
    of each variable.  Many bindings are ground with arrays
    (:func:`~cplus.ground.vector.ground_vectorized`, generator ``first`` as the first axis),
    few with the law's closures."""
    law = prep.law
    g.at = ("grounding this law", law.loc)
    if prep.variables:
        order = [first] + [j for j in range(len(gens)) if j != first]
        joins = [(gens[j].node, gens[j].pattern, [(*args, value) for args, value in pools[j]]) for j in order]
        done = ground_vectorized(g, law, prep.variables, prep.filters, prep.head_slot, joins)
        if done is not None:
            g.theory.rules[law.cls].extend(done[0])
            g.theory.constraints[law.cls].extend(done[1])
            g._check_rules(law.loc)
            return
    env: dict = {}
    for fn, vs in prep.filters:
        if not vs and fn(env, 0) is not True:
            return
    levels = binding_levels(g.sig, prep.variables, prep.filters)
    rank = {name: i for i, (name, _, _) in enumerate(levels)}
    # each generator acts at the level of its last variable: it lists the values of that
    # variable given the others (a join), or, when another generator already does, checks
    gen_at: dict[int, tuple] = {}
    checks_at: dict[int, list] = {}
    for gen, pool in zip(gens, pools):
        pattern = gen.pattern
        names = list(dict.fromkeys(x for is_var, x in pattern if is_var))
        rows = matching(pattern, names, doms, ((*args, value) for args, value in pool))
        if not names:
            if not rows:
                return
            continue
        last = max(names, key=rank.__getitem__)
        at = rank[last]
        if at not in gen_at:
            others = [n for n in names if n != last]
            index: dict[tuple, list] = {}
            k = names.index(last)
            for row in rows:
                index.setdefault(tuple(v for i, v in enumerate(row) if i != k), []).append(row[k])
            gen_at[at] = (others, index)
        else:
            checks_at.setdefault(at, []).append((names, set(rows)))
    depth = len(levels)
    solvers = level_solvers(levels)
    _check_tries(g, prep, levels, solvers, gen_at, checks_at)
    leaf = prep.leaf
    seen_count = [0]
    check, loc = g._check_rules, law.loc
    tries = [0]
    limit = limits.MAX_TRIES

    def rec(i: int) -> None:
        if i == depth:
            leaf(env)
            seen_count[0] += 1
            if not seen_count[0] & 4095:
                check(loc)
            return
        name, dom, fl = levels[i]
        gen = gen_at.get(i)
        if gen is not None:
            dom = gen[1].get(tuple([env[n] for n in gen[0]]), ())
        elif solvers[i] is not None and dom:
            got = solvers[i](env)       # type: ignore[misc]
            if got is not None:
                dom = tuple([v for v in got if v in doms[name]])
        tries[0] += len(dom)
        if tries[0] > limit:
            raise GroundingError(too_many_tries(tries[0], list(prep.variables), limit, tried=True), loc)
        member = checks_at.get(i, ())
        for v in dom:
            env[name] = v
            for names, rows in member:
                if tuple([env[n] for n in names]) not in rows:
                    break
            else:
                for fn in fl:
                    if fn(env, 0) is not True:
                        break
                else:
                    rec(i + 1)
        env.pop(name, None)
    rec(0)


def _check_tries(g, prep, levels: list, solvers: list, gen_at: dict, checks_at: dict) -> None:
    """:meth:`~cplus.ground.theory._Grounder._check_tries` for the levels of a joined law: a
    generator's level tries the values its possible atoms give (at most its largest group)."""
    sizes = [max(map(len, gen_at[i][1].values()), default=0) if i in gen_at
             else len(dom) if solve is None else min(1, len(dom))
             for i, ((_, dom, _), solve) in enumerate(zip(levels, solvers))]

    def probe() -> list:
        out = []
        for i, ((name, dom, fl), solve) in enumerate(zip(levels, solvers)):
            gen = gen_at.get(i)
            options = _lookup(gen[0], gen[1]) if gen is not None else options_of(dom, solve)
            tests = [_member(names, rows) for names, rows in checks_at.get(i, ())]
            tests += [passing(fn) for fn in fl]
            out.append((name, options, tests))
        return out
    g._check_tries(levels, list(prep.variables), prep.law.loc, sizes, probe)


def _member(names: list[str], rows: set) -> Callable[[dict], bool]:
    return lambda env: tuple([env[n] for n in names]) in rows


def _lookup(others: list[str], index: dict) -> Callable[[dict], list]:
    """A generator's values of its level's variable, given its ``others`` in ``env``."""
    return lambda env: index.get(tuple([env[n] for n in others]), [])


# --------------------------------------------------------------------------- the initial state


def fixed_at_zero(sig, atoms, query) -> set[int]:
    """Positive atoms of non-rigid constants that the query's permanent items force at step 0
    (other literals are read as true, which only weakens the items: what the weakened items
    force, the items force)."""
    def mklit(aid: int, t: object) -> PF:
        return aid if t == 0 and not atoms.gc_of[abs(aid)].decl.kind == "rigid" else True
    ctx = Ctx(sig, atoms, mklit)
    fixed: set[int] = set()
    for formula, _ in query.items:
        if ir.mentions(formula, (ir.MaxStepT,)) or has_step_var(formula):
            continue
        try:
            pf = ground_formula(sig, formula, ctx, query.lo)
        except Exception:   # the real grounding of the item reports it
            continue
        items = pf[1] if type(pf) is tuple and pf[0] == "&" else (pf,)
        fixed.update(g for g in items if type(g) is int and g > 0)
    return fixed


def ground_formula(sig, formula: ir.Formula, ctx: Ctx, maxstep: int) -> PF:
    fn = compile_formula(formula, ctx)
    parts: list[PF] = []
    bind(sig, ir.free_vars(formula), [], lambda env: parts.append(fn(env, None)), {"$maxstep": maxstep})
    return mk_and(parts)


def has_step_var(f) -> bool:
    """Whether a query item has a variable over steps (free or quantified)."""
    return any(isinstance(v.sort, StepSort) for v in ir.free_vars(f).values()) or _quant_step(f)


def _quant_step(f) -> bool:
    if isinstance(f, ir.Quant):
        return isinstance(f.var.sort, StepSort) or _quant_step(f.body)
    if isinstance(f, (ir.And, ir.Or)):
        return any(_quant_step(x) for x in f.items)
    if isinstance(f, ir.Not):
        return _quant_step(f.arg)
    if isinstance(f, (ir.Imp, ir.Iff)):
        return _quant_step(f.left) or _quant_step(f.right)
    if isinstance(f, ir.StampF):
        return _quant_step(f.body)
    return False
