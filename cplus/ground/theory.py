"""Ground a program into step templates of basic causal rules.

The result does not depend on the plan length: every rule is stamped with *slots*
relative to a step i (slot 0 = step i, slot 1 = step i+1, slot 2 = rigid, unstamped), and
the SAT layer instantiates the templates for each step.  A template literal is
``±(atom * 3 + slot + 1)``.

* ``rigid`` rules and constraints: one copy;
* ``static`` ones: at every step 0..m (slot 0);
* ``action`` ones: at every action step 0..m-1 (slot 0);
* ``dynamic`` ones: head at slot 1, ``after`` part at slot 0, for every transition.

Laws implied by declarations are added here from each constant's kind: inertia, exogeneity
of exogenous actions and attributes, the attribute axiom ``c=none <->> -a``, the defaults
of abnormalities and of additive contributions.  Additive fluents and actions get hidden
contribution constants (Lee & Lifschitz 2003) whose sums the SAT layer encodes.
"""
from __future__ import annotations

import time as _time
from collections.abc import Callable

from cplus import ir, limits
from cplus.errors import GroundingError, Location, OutOfMemoryError, SortError
from cplus.ground.atoms import AtomTable
from cplus.ground.compile import (
    UNDEF,
    Cases,
    Ctx,
    bind,
    binding_levels,
    combine,
    compile_formula,
    compile_term,
    domain_of,
    evaluate_parts,
    level_solvers,
    too_many_tries,
)
from cplus.ground.cost import bind_levels, probed_tries, sampled_instances, tries_bound
from cplus.ground.equations import attach
from cplus.ground.pf import PF, mk_and, neg
from cplus.ground.vector import ground_vectorized
from cplus.limits import RULE_BYTES, count, too_large
from cplus.program import BasicLaw, IncrementLaw, Program
from cplus.record import Record
from cplus.signature import SIMPLE_KINDS, ConstDecl, GroundConst, RangeSort, StepSort

__all__ = ["GroundTheory", "AdditiveSum", "ground_program", "template_lit", "SLOT_NOW", "SLOT_NEXT",
           "SLOT_RIGID", "initially_free"]

SLOT_NOW, SLOT_NEXT, SLOT_RIGID = 0, 1, 2
CLASSES = ("rigid", "static", "action", "dynamic")


def template_lit(aid: int, slot: int) -> int:
    return aid * 3 + slot + 1 if aid > 0 else -(-aid * 3 + slot + 1)


class AdditiveSum(Record):
    """``target`` (at slot 1 for a fluent, slot 0 for an action) = base + sum of contributions."""

    _fields = ("target", "contributions")

    target: GroundConst
    contributions: list[GroundConst]

    def __init__(self, target: GroundConst, contributions: list[GroundConst]) -> None:
        self.target = target
        self.contributions = contributions


class GroundTheory(Record):
    _fields = ("program", "atoms", "rules", "constraints", "sums", "noconcurrency", "rule_count", "seconds",
               "initial", "dead")

    program: Program
    atoms: AtomTable
    rules: dict[str, list[tuple[int, PF]]]
    constraints: dict[str, list[PF]]
    sums: list[AdditiveSum]
    noconcurrency: list[list[PF]]
    rule_count: int
    seconds: float
    initial: frozenset[int] | None
    """Set when the theory was ground for one initial state (:mod:`cplus.ground.restrict`):
    the positive atoms fixed at step 0; rules that need an unreachable value are left out."""
    dead: frozenset[int]
    """With :attr:`initial`: the fluent values no history from that state can take."""

    def __init__(
            self,
            program: Program,
            atoms: AtomTable,
            rules: dict[str, list[tuple[int, PF]]] | None = None,
            constraints: dict[str, list[PF]] | None = None,
            sums: list[AdditiveSum] | None = None,
            noconcurrency: list[list[PF]] | None = None,
            rule_count: int = 0,
            seconds: float = 0.0,
            initial: frozenset[int] | None = None,
            dead: frozenset[int] = frozenset()) -> None:
        self.program = program
        self.atoms = atoms
        self.rules = {c: [] for c in CLASSES} if rules is None else rules
        self.constraints = {c: [] for c in CLASSES} if constraints is None else constraints
        self.sums = [] if sums is None else sums
        self.noconcurrency = [] if noconcurrency is None else noconcurrency
        self.rule_count = rule_count
        self.seconds = seconds
        self.initial = initial
        self.dead = dead

    @property
    def sig(self):
        return self.program.signature


class PreparedLaw(Record):
    """A law ready to ground: ``leaf(env)`` appends the rules of one binding of
    ``variables`` that passes ``filters`` (see :meth:`_Grounder.prepare`)."""

    _fields = ("law", "variables", "filters", "leaf", "head_slot")

    law: BasicLaw
    variables: dict[str, ir.Var]
    filters: list
    leaf: Callable[[dict], None]
    head_slot: int

    def __init__(
            self,
            law: BasicLaw,
            variables: dict[str, ir.Var],
            filters: list,
            leaf: Callable[[dict], None],
            head_slot: int) -> None:
        self.law = law
        self.variables = variables
        self.filters = filters
        self.leaf = leaf
        self.head_slot = head_slot


class _Grounder:
    def __init__(self, program: Program, initial: set[int] | None = None) -> None:
        self.program = program
        self.initial = initial
        self.sig = program.signature
        self.atoms = AtomTable(self.sig)
        self.theory = GroundTheory(program, self.atoms)
        rigid = self._rigid_flags()
        self.rigid = rigid

        def mklit(aid: int, slot: object) -> PF:
            if aid == 0:
                return False
            a = aid if aid > 0 else -aid
            if rigid[a]:
                slot = SLOT_RIGID
            code = a * 3 + slot + 1  # type: ignore[operator]
            return code if aid > 0 else -code
        self.ctx = Ctx(self.sig, self.atoms, mklit)
        self.mklit = mklit
        self.warned: set[int] = set()
        self.rule_budget = limits.memory_budget() // RULE_BYTES
        self.at: tuple[str, Location | None] = ("grounding", None)
        """What is being ground, for a :class:`MemoryError`: what it is, and where."""

    def _rigid_flags(self) -> list[bool]:
        flags = [False] * (len(self.atoms) + 1)
        for aid in range(1, len(self.atoms) + 1):
            gc = self.atoms.gc_of[aid]
            flags[aid] = gc is not None and gc.decl.kind == "rigid"
        return flags

    def run(self) -> GroundTheory:
        """The ground theory; a :class:`MemoryError` (an address-space limit reached) is
        reported as the law, or the declaration, being ground then being too large."""
        try:
            return self._run()
        except MemoryError:
            pass        # the exception, and what the frames it holds built, are released here
        doing, loc = self.at
        raise OutOfMemoryError(limits.out_of_memory(doing), loc)

    def _run(self) -> GroundTheory:
        t0 = _time.perf_counter()
        self._increments()
        if self.initial:
            from cplus.ground.restrict import ground_reachable
            th = self.theory
            th.dead = ground_reachable(self, self.initial)
            th.initial = frozenset(self.initial)
        else:
            for law in self.program.laws:
                self._law(law)
        for gc in list(self.sig.ground):
            self._implied(gc)
        self._noconcurrency()
        th = self.theory
        th.rule_count = sum(len(v) for v in th.rules.values()) + sum(len(v) for v in th.constraints.values())
        th.seconds = _time.perf_counter() - t0
        return th

    # ------------------------------------------------------------------ helpers
    def _split(self, formula: ir.Formula | None, slot: int, filters: list, parts: list) -> None:
        """Constant-free conjuncts become binding filters; the rest is compiled to be read at
        ``slot`` (each part is then ``(fn, slot)``, for :func:`evaluate_parts`)."""
        for c in ir.conjuncts(formula):
            fn = compile_formula(c, self.ctx)
            if not ir.constants_in(c) and not ir.mentions(c, (ir.MaxStepT, ir.StampF, ir.StampT)):
                filters.append((attach(fn, c, self.ctx), set(ir.free_vars(c))))
            else:
                parts.append((fn, slot))

    def _variables(self, *nodes) -> dict[str, ir.Var]:
        out: dict[str, ir.Var] = {}
        for n in nodes:
            if n is not None:
                for name, v in ir.free_vars(n).items():
                    out.setdefault(name, v)
        for v in out.values():
            if isinstance(v.sort, StepSort):
                raise GroundingError(f"variable {v.name} ranges over steps, which exist only in queries", v.loc)
        return out


    def _bind(self, variables: dict[str, ir.Var], filters: list, leaf, loc: Location) -> None:
        """:func:`bind` with a memory and a time check (:mod:`cplus.ground.cost`).  When the
        product of the variables' domains is more than could fit, the share of combinations
        that pass the law's conditions is estimated from a fixed sample, and the law refused
        at once if that is still too many; so is a law whose grounding would try more than
        :data:`~cplus.limits.MAX_TRIES` values.  Any law is stopped as soon as the rules
        grounded so far cannot fit (checked every 4096 bindings), or its tries reach that
        limit."""
        doms = {n: domain_of(self.sig, v, {}) for n, v in variables.items()}
        cells = 1
        for d in doms.values():
            cells *= len(d)
        if cells > self.rule_budget:
            estimate = cells if not filters else sampled_instances(doms, filters, cells)
            if estimate > self.rule_budget:
                names = ", ".join(variables)
                what = "every combination" if not filters else "the combinations that pass the conditions"
                raise GroundingError(too_large(f"this law has about {count(estimate)} instances ({what} of "
                                               f"{names})", estimate * RULE_BYTES), loc)
        self._check_tries(binding_levels(self.sig, variables, filters), list(variables), loc)
        seen = [0]
        check = self._check_rules

        def counted(env: dict) -> None:
            leaf(env)
            seen[0] += 1
            if not seen[0] & 4095:
                check(loc)
        try:
            bind(self.sig, variables, filters, counted, max_tries=limits.MAX_TRIES)
        except GroundingError as exc:
            if exc.loc is None:
                exc.loc = loc
            raise

    def _check_tries(self, levels: list, names: list[str], loc: Location,
                     sizes: list[int] | None = None, probe: Callable[[], list] | None = None) -> None:
        """Refuse a law whose grounding would try more than :data:`~cplus.limits.MAX_TRIES`
        values over its binding ``levels`` (``sizes`` and ``probe``: what
        :func:`~cplus.ground.cost.bind_levels` gives, for a caller that binds otherwise)."""
        if sizes is None or probe is None:
            sizes, probe = bind_levels(levels, level_solvers(levels))
        if tries_bound(sizes) <= limits.MAX_TRIES:
            return
        estimate = probed_tries(probe())
        if estimate > limits.MAX_TRIES:
            raise GroundingError(too_many_tries(estimate, names, limits.MAX_TRIES), loc)

    def _check_rules(self, loc: Location) -> None:
        th = self.theory
        total = sum(map(len, th.rules.values())) + sum(map(len, th.constraints.values()))
        if total > self.rule_budget:
            raise GroundingError(too_large(f"grounding reached {count(total)} rules at this law", total * RULE_BYTES),
                                 loc)

    # ------------------------------------------------------------------ laws
    def _law(self, law: BasicLaw) -> None:
        prep = self.prepare(law)
        if prep is None:
            return
        if law.frame is None and prep.variables:
            done = ground_vectorized(self, law, prep.variables, prep.filters, prep.head_slot)
            if done is not None:
                self.theory.rules[law.cls].extend(done[0])
                self.theory.constraints[law.cls].extend(done[1])
                self._check_rules(law.loc)
                return
        self._bind(prep.variables, prep.filters, prep.leaf, law.loc)

    def prepare(self, law: BasicLaw) -> PreparedLaw | None:
        """A law compiled for grounding: its variables, its constant-free conditions
        (binding filters) and the leaf that appends the rules of one binding; None when the
        law yields nothing (head ``true``)."""
        self.at = ("grounding this law", law.loc)
        head_slot = SLOT_NEXT if law.cls == "dynamic" else SLOT_NOW
        variables = self._variables(law.head, law.body, law.after, law.where, law.frame_cst)
        filters: list = []
        parts: list = []
        self._split(law.where, head_slot, filters, parts)
        if parts:
            raise GroundingError("a 'where' condition may not mention constants", law.loc)
        self._split(law.body, head_slot, filters, parts)
        self._split(law.after, SLOT_NOW, filters, parts)
        rules = self.theory.rules[law.cls]
        constraints = self.theory.constraints[law.cls]

        if law.frame is not None:
            return PreparedLaw(law, variables, filters, self._frame_leaf(law, parts, rules, constraints), head_slot)
        heads = [self._head_fn(h) for h in ir.conjuncts(law.head)] if law.head is not None else None
        if heads == []:   # head `true`
            return None
        body_of = evaluate_parts(parts)

        def leaf(env: dict) -> None:
            body = body_of(env, 0)
            if body is False:
                return
            if heads is None:
                constraints.append(body)
                return
            for hf in heads:
                for lit, cond in hf(env, head_slot):
                    b = mk_and((body, cond)) if cond is not True else body
                    if b is False:
                        continue
                    if lit is None:
                        constraints.append(b)
                    else:
                        rules.append((lit, b))
        return PreparedLaw(law, variables, filters, leaf, head_slot)

    def _head_fn(self, h: ir.Formula):
        """Compile one head conjunct into ``fn(env, slot) -> [(literal or None, condition)]``."""
        if isinstance(h, ir.Truth):
            return lambda env, slot: [] if h.value else [(None, True)]
        negated = isinstance(h, ir.Not)
        atom = h.arg if negated else h  # type: ignore[union-attr]
        assert isinstance(atom, ir.Atom)
        value_fn = compile_term(atom.value, self.ctx)
        lit_of = self.atoms.lit
        mklit = self.mklit
        warn_loc = atom.loc
        if isinstance(atom.cst, ir.Var):
            name = atom.cst.name
            gc_fn = lambda env, slot: env[name]  # noqa: E731
        elif all(isinstance(a, (ir.Var, ir.Lit)) for a in atom.cst.args):
            instances = atom.cst.decl.instances
            getters = [(True, a.name) if isinstance(a, ir.Var) else (False, a.value) for a in atom.cst.args]  # type: ignore[union-attr]
            plain_value = isinstance(atom.value, (ir.Var, ir.Lit))

            def head_simple(env, slot):   # the common case: no constant inside the head
                gc = instances.get(tuple([env[x] if is_var else x for is_var, x in getters]))
                if gc is None:
                    return []
                v = value_fn(env, slot)
                if plain_value or (type(v) is not Cases and v is not UNDEF):
                    aid = lit_of(gc, v)
                    if aid:
                        lit = mklit(aid, slot)
                        return [(neg(lit) if negated else lit, True)]
                return head(env, slot)
            gc_fn = compile_term(atom.cst, self.ctx, names=True)
        else:
            # a constant inside the head's arguments: one head per value of it (C.8)
            arg_fns = [compile_term(a, self.ctx) for a in atom.cst.args]
            instances = atom.cst.decl.instances

            def gc_fn(env, slot):
                args = [f(env, slot) for f in arg_fns]
                if any(type(a) is Cases for a in args):
                    return combine(args, lambda a: instances.get(tuple(a), UNDEF))
                return instances.get(tuple(args), UNDEF)

        def head(env, slot):
            gcs = gc_fn(env, slot)
            gcs = gcs if type(gcs) is Cases else [(True, gcs)]
            v = value_fn(env, slot)
            vals = v if type(v) is Cases else [(True, v)]
            out = []
            for cg, gc in gcs:
                if gc is UNDEF:
                    continue
                for cv, val in vals:
                    cond = mk_and((cg, cv))
                    if cond is False:
                        continue
                    aid = lit_of(gc, val) if val is not UNDEF else 0
                    if aid == 0:
                        self._warn_domain(warn_loc, gc, val)
                        out.append((None, cond))
                        continue
                    lit = mklit(aid, slot)
                    out.append((neg(lit) if negated else lit, cond))
            return out
        if isinstance(atom.cst, ir.Cst) and all(isinstance(a, (ir.Var, ir.Lit)) for a in atom.cst.args):
            return head_simple
        return head

    def _warn_domain(self, loc: Location, gc: GroundConst, val) -> None:
        if loc.start in self.warned:
            return
        self.warned.add(loc.start)
        from cplus.signature import render_value
        shown = "undefined" if val is UNDEF else render_value(val)
        self.program.diagnostics.warn(
            f"the head value {shown} is outside the domain of {gc.text}; such instances act as "
            "'caused false' (guard the law with 'where')", loc)

    def _frame_leaf(self, law: BasicLaw, parts, rules, constraints):
        gc_fn = compile_term(law.frame_cst, self.ctx, names=True)  # type: ignore[arg-type]
        ctx_values = self.ctx.values
        mklit = self.mklit
        body_of = evaluate_parts(parts)
        frame = law.frame

        def leaf(env: dict) -> None:
            gc = gc_fn(env, 0)
            if gc is UNDEF or type(gc) is Cases:
                return
            body = body_of(env, 0)
            if body is False:
                return
            for aid, _ in ctx_values(gc):
                if frame == "exogenous":
                    lit = mklit(aid, SLOT_NOW)
                    rules.append((lit, mk_and((lit, body))))
                elif frame == "inertial":
                    lit1 = mklit(aid, SLOT_NEXT)
                    rules.append((lit1, mk_and((lit1, mklit(aid, SLOT_NOW), body))))
                else:  # rigid c: false if -(c=v) after c=v
                    constraints.append(mk_and((neg(mklit(aid, SLOT_NEXT)), mklit(aid, SLOT_NOW), body)))
        return leaf

    # ------------------------------------------------------------------ implied laws
    def _implied(self, gc: GroundConst) -> None:
        self.at = ("grounding the laws this declaration implies", gc.decl.loc)
        kind = gc.decl.kind
        rules = self.theory.rules
        lits = self.atoms.head_lits(gc)
        mk = self.mklit
        if kind == "inertialFluent":
            for aid, _ in lits:
                l1 = mk(aid, SLOT_NEXT)
                rules["dynamic"].append((l1, mk_and((l1, mk(aid, SLOT_NOW)))))  # type: ignore[arg-type]
        elif kind in ("exogenousAction", "attribute"):
            for aid, _ in lits:
                lit = mk(aid, SLOT_NOW)
                rules["action"].append((lit, lit))  # type: ignore[arg-type]
            if kind == "attribute":
                self._attribute_axiom(gc)
        elif kind == "contribution":     # (an abnormality's default comes with its first `unless`)
            aid = self.atoms.lit(gc, 0)
            if aid:
                lit = mk(aid, SLOT_NOW)
                rules["action"].append((lit, lit))  # type: ignore[arg-type]

    def _attribute_axiom(self, gc: GroundConst) -> None:
        parent = gc.decl.parent
        assert parent is not None
        pg = parent.instances.get(gc.args[:parent.arity])
        if pg is None:
            return
        if pg.boolean:
            p = self.mklit(self.atoms.lit(pg, "true"), SLOT_NOW)
        else:
            none = self.atoms.lit(pg, "none")
            if not none:
                raise SortError(f"the attribute '{gc.decl.name}' needs its non-Boolean action "
                                f"'{parent.name}' to have 'none' in its domain", gc.decl.loc)
            p = neg(self.mklit(none, SLOT_NOW))
        n = self.mklit(self.atoms.lit(gc, "none"), SLOT_NOW)
        cons = self.theory.constraints["action"]
        cons.append(mk_and((n, p)))
        cons.append(mk_and((neg(n), neg(p))))

    # ------------------------------------------------------------------ additive constants
    def _increments(self) -> None:
        groups: dict[tuple[int, object], list] = {}
        order: list[tuple[GroundConst, PF]] = []
        for inc in self.program.increments:
            self._increment(inc, groups, order)
        m = self.sig.max_additive or 0
        # the hidden constants are made once per signature: a program ground again (for
        # another query's initial state) gets the same ones, so every theory of it agrees on
        # the signature's ground constants
        made = self.sig.made
        decl = made.get("decl")
        if decl is None:
            decl = made["decl"] = ConstDecl("contribution", (), "contribution", RangeSort(-m, m), None, hidden=True)
        by_target: dict[int, list[GroundConst]] = {}
        for target, action in order:
            entries = groups[(target.id, action)]
            amounts = sorted({0} | {n for n, _ in entries if -m <= n <= m})
            key = (target.id, action, tuple(amounts))
            cg = made.get(key)
            if cg is None:
                cg = made[key] = self.sig.add_hidden_instance(decl, (target.text, len(self.sig.ground)),
                                                              tuple(amounts))
            self.atoms.add(cg)
            self.rigid.extend([False] * (len(self.atoms) + 1 - len(self.rigid)))
            by_target.setdefault(target.id, []).append(cg)
            for n, body in entries:
                aid = self.atoms.lit(cg, n)
                if aid:
                    self.theory.rules["action"].append((self.mklit(aid, SLOT_NOW), body))  # type: ignore[arg-type]
                else:   # a contribution outside -maxAdditive..maxAdditive cannot be caused
                    self.theory.constraints["action"].append(body)
        for gc in self.sig.ground:
            if gc.decl.kind in ("additiveFluent", "additiveAction"):
                self.theory.sums.append(AdditiveSum(gc, by_target.get(gc.id, [])))

    def _increment(self, inc: IncrementLaw, groups: dict, order: list) -> None:
        self.at = ("grounding this law", inc.loc)
        variables = self._variables(inc.action, inc.target, inc.amount, inc.cond, inc.where)
        filters: list = []
        parts: list = []
        self._split(inc.where, SLOT_NOW, filters, parts)
        self._split(inc.cond, SLOT_NOW, filters, parts)
        action_fn = compile_formula(inc.action, self.ctx)
        target_fn = compile_term(inc.target, self.ctx, names=True)
        amount_fn = compile_term(inc.amount, self.ctx)
        sign = -1 if inc.decrement else 1
        body_of = evaluate_parts(parts)

        def leaf(env: dict) -> None:
            target = target_fn(env, 0)
            if target is UNDEF or type(target) is Cases:
                return
            amount = amount_fn(env, 0)
            if type(amount) is not int:
                raise GroundingError("the amount of 'increments' must be an integer", inc.loc)
            action = action_fn(env, SLOT_NOW)
            if action is False:
                return
            body = body_of(env, 0)
            if body is False:
                return
            key = (target.id, action)
            if key not in groups:
                groups[key] = []
                order.append((target, action))
            groups[key].append((sign * amount, mk_and((action, body))))
        self._bind(variables, filters, leaf, inc.loc)

    # ------------------------------------------------------------------ noconcurrency
    def _noconcurrency(self) -> None:
        if not self.program.noconcurrency:
            return
        strong = any(s for s, _ in self.program.noconcurrency)
        group: list[PF] = []
        for gc in self.sig.ground:
            if gc.decl.kind not in ("exogenousAction", "action") or gc.decl.hidden:
                continue
            if gc.boolean:
                group.append(self.mklit(self.atoms.lit(gc, "true"), SLOT_NOW))
            elif strong and self.atoms.lit(gc, "none"):
                group.append(neg(self.mklit(self.atoms.lit(gc, "none"), SLOT_NOW)))
        if len(group) > 1:
            self.theory.noconcurrency.append(group)


def ground_program(program: Program, initial: set[int] | None = None) -> GroundTheory:
    """Ground every law of a resolved program into step templates.

    ``initial``: positive atoms that hold at step 0 in every history wanted (a query's
    initial state, see :func:`cplus.ground.restrict.fixed_at_zero`).  When given (and not
    empty) only the instances that can matter from that state are ground: the theory is then
    for that state only (:attr:`GroundTheory.initial`)."""
    return _Grounder(program, initial).run()


def initially_free(decl: ConstDecl) -> bool:
    """Simple, inertial and additive fluents take any value at step 0 (C.3)."""
    return decl.kind in SIMPLE_KINDS

