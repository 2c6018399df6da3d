"""Compile resolved formulas and terms into closures that ground them.

A compiled term is ``fn(env, time) -> value``, where ``env`` maps variable names to
objects and ``time`` is the step slot (laws) or the absolute step (queries) at which
constants are read.  A term that mentions constants has no single value: it evaluates to
:class:`Cases`, the list of ``(condition, value)`` pairs over the constants' values
(section C.8 of the language reference).  A compiled formula returns a propositional
formula (:mod:`cplus.ground.pf`) whose literals come from ``ctx.mklit``.

Compiling once and calling the closure for every binding keeps the per-instance cost low,
and it is a safe evaluator: no Python ``eval``, arithmetic only on integers.
"""
from __future__ import annotations

from collections.abc import Callable

from cplus import ir
from cplus.errors import GroundingError, Location
from cplus.ground.arith import ARITH_FUNCTIONS
from cplus.ground.atoms import AtomTable
from cplus.ground.intexpr import int_comparison, int_term
from cplus.ground.pf import PF, mk_and, mk_or, neg
from cplus.limits import MAX_INT, count
from cplus.signature import GroundConst, Signature, StepSort, order_key, render_value

__all__ = ["Cases", "UNDEF", "Ctx", "compile_term", "compile_formula", "evaluate_all", "evaluate_parts", "domain_of", "bind",
           "combine", "level_solvers", "Solver"]


class Cases(list):
    """Possible values of a term with constants: ``[(condition_pf, value), ...]``."""

    __slots__ = ()


class _Undef:
    __slots__ = ()

    def __repr__(self) -> str:
        return "UNDEF"


UNDEF = _Undef()
"""The value of undefined arithmetic (a non-integer operand): that case is false."""

MkLit = Callable[[int, object], PF]


class Ctx:
    """What compiled code needs: the signature, the atoms, and how to make a literal."""

    def __init__(self, sig: Signature, atoms: AtomTable, mklit: MkLit) -> None:
        self.sig = sig
        self.atoms = atoms
        self.mklit = mklit
        self._cases: dict[int, list] = {}

    def values(self, gc: GroundConst) -> list:
        """``(atom, value)`` pairs of a ground constant (cached)."""
        got = self._cases.get(gc.id)
        if got is None:
            got = self._cases[gc.id] = self.atoms.head_lits(gc)
        return got


def domain_of(sig: Signature, var: ir.Var, env: dict) -> tuple:
    if isinstance(var.sort, StepSort):
        m = env.get("$maxstep")
        if m is None:
            raise GroundingError(f"variable {var.name} ranges over steps, which exist only in queries", var.loc)
        return tuple(range(0, m if var.sort.action else m + 1))
    return sig.objects_of(var.sort)


def combine(vals: list, fn: Callable[[list], object]) -> Cases:
    """Apply ``fn`` to every combination of the possible values of ``vals``."""
    combos: list[tuple[PF, list]] = [(True, [])]
    for v in vals:
        if type(v) is Cases:
            combos = [(mk_and((c, vc)), acc + [vv]) for c, acc in combos for vc, vv in v]
        else:
            combos = [(c, acc + [v]) for c, acc in combos]
    out = Cases()
    for cond, args in combos:
        if cond is False:
            continue
        r = fn(args)
        if r is UNDEF:
            continue
        out.append((cond, r))
    return out


# --------------------------------------------------------------------------- terms


def compile_term(t: ir.Term, ctx: Ctx, names: bool = False) -> Callable:
    """``names``: constants stand for themselves (``==``), not for their values."""
    if isinstance(t, ir.Lit):
        v = t.value
        return lambda env, time: v
    if isinstance(t, ir.Var):
        name = t.name
        return lambda env, time: env[name]
    if isinstance(t, ir.Arith):
        return _compile_arith(t, ctx, names)
    if isinstance(t, ir.Cst):
        return _compile_cst_term(t, ctx, names)
    if isinstance(t, ir.Obj):
        fns = [compile_term(a, ctx, names) for a in t.args]
        head = t.name

        def obj(env, time):
            vals = [f(env, time) for f in fns]
            if any(type(v) is Cases for v in vals):
                return combine(vals, lambda a: (head,) + tuple(a))
            return (head,) + tuple(vals)
        return obj
    if isinstance(t, ir.MaxStepT):
        loc = t.loc

        def maxstep(env, time):
            try:
                return env["$maxstep"]
            except KeyError:
                raise GroundingError("'maxstep' has no value here", loc) from None
        return maxstep
    if isinstance(t, ir.StampT):
        tf = compile_term(t.time, ctx)
        inner = compile_term(t.term, ctx, names)
        loc = t.loc

        def stamped(env, time):
            return inner(env, _time_value(tf(env, time), loc))
        return stamped
    if isinstance(t, ir.Ext):
        fns = [compile_term(a, ctx, names) for a in t.args]
        fn, name, loc = t.fn, t.name, t.loc
        objects = ctx.sig.object_order

        def ext(env, time):
            args = [f(env, time) for f in fns]
            if any(type(a) is Cases for a in args):
                raise GroundingError(f"the arguments of external '{name}' may not mention constants", loc)
            return _term_result(_call_external(fn, name, args, loc), objects, name, args, loc)
        return ext
    raise TypeError(t)  # pragma: no cover


def _call_external(fn, name: str, args: list, loc: Location):
    """Call an external (user code): what it raises, or an attempt to end the program
    (``sys.exit``), is a grounding error naming the call."""
    try:
        return fn(*args)
    except Exception as exc:
        raise GroundingError(f"external {_call(name, args)} failed: {type(exc).__name__}: {_brief(exc)}",
                             loc) from None
    except SystemExit as exc:
        raise GroundingError(f"external {_call(name, args)} tried to end the program "
                             f"(sys.exit({_brief(exc.code, repr)}))", loc) from None


def _call(name: str, args: list) -> str:
    return f"'{name}({','.join(render_value(a) for a in args)})'"


def _brief(value: object, show: Callable[[object], str] = str) -> str:
    """What an external gave, for a message: at most 80 characters, whatever it is."""
    try:
        text = show(value)
    except Exception:  # noqa: BLE001 - a user object whose repr fails
        text = f"<a {type(value).__name__}>"
    return text if len(text) <= 80 else text[:77] + "..."


def _term_result(value: object, objects: dict, name: str, args: list, loc: Location) -> object:
    """An external function's value: a 64-bit integer or an object of the domain."""
    if type(value) is int:
        if -MAX_INT - 1 <= value <= MAX_INT:
            return value
        raise GroundingError(f"external {_call(name, args)} returned {count(value)}, outside the integers "
                             f"(-2^63..2^63-1)", loc)
    if type(value) in (str, tuple):
        try:
            if value in objects:
                return value
        except TypeError:   # a tuple holding something unhashable
            pass
    elif _numpy_scalar(value, "int"):
        return _term_result(int(value), objects, name, args, loc)    # type: ignore[call-overload]
    raise GroundingError(f"external {_call(name, args)} returned {_brief(value, repr)}, which is neither an "
                         f"integer nor an object of this domain", loc)


def _truth(value: object, name: str, args: list, loc: Location) -> bool:
    """An external predicate's value: True or False (numpy's booleans too)."""
    if value is True or value is False:
        return value
    if _numpy_scalar(value, "bool"):
        return bool(value)
    raise GroundingError(f"external predicate {_call(name, args)} returned {_brief(value, repr)}, "
                         f"not True or False", loc)


def _numpy_scalar(value: object, kind: str) -> bool:
    """Whether ``value`` is a numpy integer (``kind`` "int") or boolean ("bool") scalar,
    without importing numpy."""
    cls = type(value)
    if cls.__module__ != "numpy":
        return False
    if kind == "bool":
        return cls.__name__ in ("bool_", "bool")
    return cls.__name__.startswith(("int", "uint")) and cls.__name__[-1].isdigit()     # int64, uint8, ...


def _time_value(v, loc: Location) -> int:
    if type(v) is int:
        return v
    raise GroundingError("a time stamp must be an integer", loc)


def _compile_arith(t: ir.Arith, ctx: Ctx, names: bool) -> Callable:
    fns = [compile_term(a, ctx, names) for a in t.args]
    op = ARITH_FUNCTIONS[t.op]
    loc = t.loc

    def apply(vals):
        for v in vals:
            if type(v) is not int:
                return UNDEF
        try:
            return op(*vals)
        except ZeroDivisionError:
            return UNDEF

    if len(fns) == 2:
        f0, f1 = fns

        def arith2(env, time):
            a, b = f0(env, time), f1(env, time)
            if type(a) is int and type(b) is int:
                try:
                    return op(a, b)
                except ZeroDivisionError:
                    raise GroundingError("division by zero", loc) from None
            if type(a) is Cases or type(b) is Cases:
                return combine([a, b], apply)
            return UNDEF
        return int_term(t, arith2)

    def arith(env, time):
        vals = [f(env, time) for f in fns]
        if any(type(v) is Cases for v in vals):
            return combine(vals, apply)
        return apply(vals)
    return int_term(t, arith)


def _compile_cst_term(t: ir.Cst, ctx: Ctx, names: bool) -> Callable:
    fns = [compile_term(a, ctx, names) for a in t.args]
    instances = t.decl.instances
    mklit = ctx.mklit
    values = ctx.values

    def gc_of(env, time):
        args = [f(env, time) for f in fns]
        if any(type(a) is Cases for a in args):
            return combine(args, lambda a: instances.get(tuple(a), UNDEF))
        return instances.get(tuple(args), UNDEF)

    if names:
        return gc_of

    def value_cases(env, time):
        gc = gc_of(env, time)
        if type(gc) is Cases:
            out = Cases()
            for cond, g in gc:
                for aid, v in values(g):
                    out.append((mk_and((cond, mklit(aid, time))), v))
            return out
        if gc is UNDEF:
            return Cases()
        return Cases((mklit(aid, time), v) for aid, v in values(gc))
    return value_cases


# --------------------------------------------------------------------------- formulas


def _compare(op: str) -> Callable[[object, object], bool]:
    if op in ("=", "=="):
        return lambda a, b: a == b
    if op == "\\==":
        return lambda a, b: a != b
    if op in ("<", ">", "=<", ">="):
        def num(a, b, op=op):
            if type(a) is int and type(b) is int:
                x, y = a, b
            else:
                x, y = order_key(a), order_key(b)
            return (x < y) if op == "<" else (x > y) if op == ">" else (x <= y) if op == "=<" else (x >= y)
        return num

    def std(a, b, op=op):
        x, y = order_key(a), order_key(b)
        return (x < y) if op == "@<" else (x > y) if op == "@>" else (x <= y) if op == "@=<" else (x >= y)
    return std


def compile_formula(f: ir.Formula, ctx: Ctx) -> Callable:
    if isinstance(f, ir.Truth):
        v = f.value
        return lambda env, time: v
    if isinstance(f, ir.Atom):
        return _compile_atom(f, ctx)
    if isinstance(f, ir.Cmp):
        return _compile_cmp(f, ctx)
    if isinstance(f, ir.Not):
        inner = compile_formula(f.arg, ctx)
        return lambda env, time: neg(inner(env, time))
    if isinstance(f, (ir.And, ir.Or)):
        return evaluate_all([compile_formula(x, ctx) for x in f.items], isinstance(f, ir.And))
    if isinstance(f, ir.Imp):
        a, b = compile_formula(f.left, ctx), compile_formula(f.right, ctx)

        def imp(env, time):
            x = a(env, time)
            if x is False:
                return True
            return mk_or((neg(x), b(env, time)))
        return imp
    if isinstance(f, ir.Iff):
        a, b = compile_formula(f.left, ctx), compile_formula(f.right, ctx)

        def iff(env, time):
            x, y = a(env, time), b(env, time)
            return mk_or((mk_and((x, y)), mk_and((neg(x), neg(y)))))
        return iff
    if isinstance(f, ir.Quant):
        return _compile_quant(f, ctx)
    if isinstance(f, ir.StampF):
        tf = compile_term(f.time, ctx)
        inner = compile_formula(f.body, ctx)
        loc = f.loc
        return lambda env, time: inner(env, _time_value(tf(env, time), loc))
    if isinstance(f, ir.ExtPred):
        fns = [compile_term(a, ctx) for a in f.args]
        fn, name, loc = f.fn, f.name, f.loc

        def ext(env, time):
            args = [g(env, time) for g in fns]
            if any(type(a) is Cases for a in args):
                raise GroundingError(f"the arguments of external '{name}' may not mention constants", loc)
            return _truth(_call_external(fn, name, args, loc), name, args, loc)
        return ext
    raise TypeError(f)  # pragma: no cover


def evaluate_all(fns: list[Callable], conjunction: bool) -> Callable:
    """``fn(env, time)``: the conjunction (or disjunction) of the compiled ``fns``, stopping at
    the first False (True)."""
    unit, build = (True, mk_and) if conjunction else (False, mk_or)
    absorbing = not unit

    def nary(env, time):
        parts = []
        for g in fns:
            r = g(env, time)
            if r is absorbing:
                return absorbing
            if r is not unit:
                parts.append(r)
        return build(parts) if parts else unit
    return nary


def evaluate_parts(parts: list[tuple[Callable, object]]) -> Callable:
    """``fn(env, _)``: the conjunction of a law's compiled parts, each read at its own slot
    (``(fn, slot)`` pairs), stopping at the first False: :func:`evaluate_all` without a call
    per part to pass its slot, since a law's parts run once per binding."""
    def conj(env, _time=None):
        out = []
        for g, slot in parts:
            r = g(env, slot)
            if r is False:
                return False
            if r is not True:
                out.append(r)
        return mk_and(out) if out else True
    return conj


def _compile_atom(f: ir.Atom, ctx: Ctx) -> Callable:
    lit_of = ctx.atoms.lit
    mklit = ctx.mklit
    if isinstance(f.cst, ir.Var):
        name = f.cst.name
        vf = compile_term(f.value, ctx)

        def var_atom(env, time):
            gc = env[name]
            v = vf(env, time)
            if type(v) is Cases:
                return mk_or(mk_and((c, _lit(gc, w, time))) for c, w in v)
            return _lit(gc, v, time)

        def _lit(gc, v, time):
            aid = lit_of(gc, v)
            return mklit(aid, time) if aid else False
        return var_atom
    fns = [compile_term(a, ctx) for a in f.cst.args]
    vf = compile_term(f.value, ctx)
    instances = f.cst.decl.instances

    def lit(gc, v, time):
        if gc is UNDEF or v is UNDEF:
            return False
        aid = lit_of(gc, v)
        return mklit(aid, time) if aid else False

    if not fns:
        gc0 = instances.get(())
        if isinstance(f.value, (ir.Var, ir.Lit)):     # pos = P: no call for the value
            value_name = f.value.name if isinstance(f.value, ir.Var) else None
            value_lit = f.value.value if isinstance(f.value, ir.Lit) else None

            def atom0_fixed(env, time):
                if gc0 is None:
                    return False
                aid = lit_of(gc0, env[value_name] if value_name is not None else value_lit)
                return mklit(aid, time) if aid else False
            return atom0_fixed

        def atom0(env, time):
            v = vf(env, time)
            if type(v) is Cases:
                return mk_or(mk_and((c, lit(gc0, w, time))) for c, w in v)
            return lit(gc0, v, time)
        return atom0

    simple = [a for a in f.cst.args if isinstance(a, (ir.Var, ir.Lit))]
    if len(simple) == len(fns):
        # the common case: arguments are variables and objects; no constant inside
        getters = [(True, a.name) if isinstance(a, ir.Var) else (False, a.value) for a in f.cst.args]  # type: ignore[union-attr]
        value_name = f.value.name if isinstance(f.value, ir.Var) else None
        value_lit = f.value.value if isinstance(f.value, ir.Lit) else None
        fixed = value_name is not None or isinstance(f.value, ir.Lit)

        def atom_simple(env, time):
            gc = instances.get(tuple([env[x] if is_var else x for is_var, x in getters]))
            if gc is None:
                return False
            if fixed:
                v = env[value_name] if value_name is not None else value_lit
            else:
                v = vf(env, time)
                if type(v) is Cases:
                    return mk_or(mk_and((c, lit(gc, w, time))) for c, w in v)
                if v is UNDEF:
                    return False
            aid = lit_of(gc, v)
            return mklit(aid, time) if aid else False
        return atom_simple

    def atom(env, time):
        args = [g(env, time) for g in fns]
        v = vf(env, time)
        for a in args:
            if type(a) is Cases:
                break
        else:
            gc = instances.get(tuple(args), UNDEF)
            if type(v) is Cases:
                return mk_or(mk_and((c, lit(gc, w, time))) for c, w in v)
            return lit(gc, v, time)
        gcs = combine(args, lambda a: instances.get(tuple(a), UNDEF))
        vals = v if type(v) is Cases else [(True, v)]
        return mk_or(mk_and((cg, cv, lit(g, w, time))) for cg, g in gcs for cv, w in vals)
    return atom


def _compile_cmp(f: ir.Cmp, ctx: Ctx) -> Callable:
    names = f.op in ("==", "\\==")
    lf, rf = compile_term(f.left, ctx, names), compile_term(f.right, ctx, names)
    rel = _compare(f.op)

    def cmp(env, time):
        a, b = lf(env, time), rf(env, time)
        ta, tb = type(a) is Cases, type(b) is Cases
        if not ta and not tb:
            if a is UNDEF or b is UNDEF:
                return False
            return rel(a, b)
        la = a if ta else [(True, a)]
        lb = b if tb else [(True, b)]
        return mk_or(mk_and((ca, cb)) for ca, va in la for cb, vb in lb
                     if va is not UNDEF and vb is not UNDEF and rel(va, vb))
    return int_comparison(f, cmp)


_MISSING = object()


def _compile_quant(f: ir.Quant, ctx: Ctx) -> Callable:
    body = compile_formula(f.body, ctx)
    var = f.var
    name = var.name
    sig = ctx.sig
    exists = f.exists

    def quant(env, time):
        dom = domain_of(sig, var, env)
        old = env.get(name, _MISSING)
        parts = []
        try:
            for v in dom:
                env[name] = v
                r = body(env, time)
                if exists:
                    if r is True:
                        return True
                    if r is not False:
                        parts.append(r)
                else:
                    if r is False:
                        return False
                    if r is not True:
                        parts.append(r)
        finally:
            if old is _MISSING:
                env.pop(name, None)
            else:
                env[name] = old
        if exists:
            return mk_or(parts) if parts else False
        return mk_and(parts) if parts else True
    return quant


# --------------------------------------------------------------------------- binding


Solver = Callable[[dict], "list | None"]
"""``solve(env) -> candidates``: the only values the variable may take given the others in
``env`` (a list of at most one), or None when the equation does not narrow it here."""

SOLVERS_ATTRIBUTE = "solutions"
"""The attribute of a compiled condition that holds its solvers by variable
(:func:`cplus.ground.equations.attach`): here, where binding reads them, so that this module
needs no import of :mod:`cplus.ground.equations`, which imports it."""


def level_solvers(levels: list) -> list[Solver | None]:
    """For each level of :func:`binding_levels`, the solver of one of the conditions completed
    there for that level's variable, or None."""
    out: list[Solver | None] = []
    for name, _, fl in levels:
        found = None
        for fn in fl:
            found = getattr(fn, SOLVERS_ATTRIBUTE, {}).get(name)
            if found is not None:
                break
        out.append(found)
    return out


def binding_levels(sig: Signature, variables: dict[str, ir.Var], filters: list[tuple[Callable, set[str]]],
                   env: dict | None = None) -> list[tuple[str, tuple, list[Callable]]]:
    """The order in which :func:`bind` binds variables: ``(name, domain, filters tested
    once it is bound)`` per level.  Variables that complete filters come first, then those
    that take part in more filters, then those with smaller domains."""
    env = {} if env is None else env
    names = list(variables)
    pending = [(fn, set(vs) & set(names)) for fn, vs in filters]
    pending = [(fn, vs) for fn, vs in pending if vs]
    doms = {n: domain_of(sig, variables[n], env) for n in names}
    order: list[str] = []
    bound: set[str] = set()
    while len(order) < len(names):
        def score(n: str):
            completes = sum(1 for _, vs in pending if n in vs and vs <= bound | {n})
            touches = sum(1 for _, vs in pending if n in vs)
            return (-completes, -touches, len(doms[n]))
        best = min((n for n in names if n not in bound), key=score)
        order.append(best)
        bound.add(best)
    levels = []
    done: set[int] = set()
    bound = set()
    for n in order:
        bound.add(n)
        fl = [fn for i, (fn, vs) in enumerate(pending) if i not in done and vs <= bound]
        done |= {i for i, (fn, vs) in enumerate(pending) if vs <= bound}
        levels.append((n, doms[n], fl))
    return levels


def bind(sig: Signature, variables: dict[str, ir.Var], filters: list[tuple[Callable, set[str]]],
         leaf: Callable[[dict], None], env: dict | None = None, max_tries: int | None = None) -> None:
    """Call ``leaf(env)`` for every binding of ``variables`` that passes every filter.

    A filter is tested as soon as all its variables are bound; variables are bound in an
    order that completes filters early, so most of the cross product is never built.  A
    variable that an equation completed at its level fixes (:mod:`cplus.ground.equations`)
    takes only that value.  ``max_tries``: a :class:`GroundingError` (with no location) once
    more values than that have been tried, passing or not.
    """
    env = {} if env is None else env
    pending = [(fn, set(vs) & set(variables)) for fn, vs in filters]
    for fn, vs in pending:
        if not vs and fn(env, 0) is not True:
            return
    levels = binding_levels(sig, variables, filters, env)
    depth = len(levels)
    if depth == 0:
        leaf(env)
        return
    solvers = level_solvers(levels)
    members: list[frozenset | None] = [None] * depth
    tries = [0]
    limit = max_tries

    def rec(i: int) -> None:
        if i == depth:
            leaf(env)
            return
        name, dom, fl = levels[i]
        solve = solvers[i]
        if solve is not None and dom:
            got = solve(env)
            if got is not None:
                member = members[i]
                if member is None:
                    member = members[i] = frozenset(dom)
                dom = tuple([v for v in got if v in member])
        if limit is not None:
            tries[0] += len(dom)
            if tries[0] > limit:
                raise GroundingError(too_many_tries(tries[0], list(variables), limit, tried=True))
        nxt = i + 1
        for v in dom:
            env[name] = v
            for fn in fl:
                if fn(env, 0) is not True:
                    break
            else:
                rec(nxt)
        env.pop(name, None)

    rec(0)


def too_many_tries(tries: int, names: list[str], limit: int, tried: bool = False) -> str:
    """The refusal of a law whose grounding tries (estimated, or ``tried`` so far) more
    bindings than ``limit``."""
    what = f"combinations of values of {', '.join(names)}"
    if tried:
        return (f"this law is too large to ground: it tried {count(tries)} {what} before it was stopped, "
                f"more than the {count(limit)} a law may try")
    return (f"this law is too large to ground: finding its instances means trying about {count(tries)} {what}, "
            f"more than the {count(limit)} a law may try")
