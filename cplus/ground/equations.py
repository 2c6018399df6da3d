"""Conditions that fix a variable: grounding ``where X + Y = 0`` binds Y from X.

:func:`~cplus.ground.compile.bind` tests a law's constant-free conditions as soon as their
variables are bound, so a condition like ``X < Y`` is tested once per pair of values.  For
an equation that is no pruning at all: with X and Y over ``0..99999`` the grounder would try
ten billion pairs to find the one that passes.  An equation is instead *solved* for the
variable bound last: at that level only the value it gives is tried (when it is in the
variable's domain), the other conditions of the level are still tested, and the bindings,
rules and their order are exactly those of trying every value.

A side of an equation is read as ``a * V + b`` for the variable ``V`` sought, with ``a`` and
``b`` computed from the variables bound already: sums, differences, negations, and products
with a factor that does not mention ``V`` (``X * Y * Z = 7`` gives ``Z = 7 // (X * Y)`` when
that divides evenly).  A side that is ``V`` alone, facing a side without ``V``, gives the
value of that side whatever object it is (``X = cell(Y)``).  Anything else (``//``, ``mod``,
``abs``, ``min``, ``max``, an external; a variable that holds an object other than an
integer, a division by zero) gives no solution: every value is tried, as before, and the
condition decides.

>>> from cplus.errors import Source, Location
>>> loc = Location(Source("x", ""), 0, 0)
>>> X, Y = ir.Var("X", None, loc), ir.Var("Y", None, loc)
>>> eq = ir.Cmp("=", ir.Arith("+", (X, Y), loc), ir.Lit(0), loc)
>>> solve = solvers_of(eq, ctx=None)["Y"]
>>> solve({"X": 7}), solve({"X": "a"})
([-7], None)
"""
from __future__ import annotations

from collections.abc import Callable

from cplus import ir
from cplus.errors import GroundingError
from cplus.ground.compile import SOLVERS_ATTRIBUTE, UNDEF, Cases, Solver, compile_term
from cplus.ground.intexpr import int_source

__all__ = ["solvers_of", "attach"]


def attach(fn: Callable, c: ir.Formula, ctx) -> Callable:
    """The compiled condition ``fn`` of ``c``, carrying the solvers of ``c`` (if any) for
    :func:`~cplus.ground.compile.level_solvers` (``fn`` is a fresh closure of
    :func:`~cplus.ground.compile.compile_formula`)."""
    solvers = solvers_of(c, ctx)
    if solvers:
        setattr(fn, SOLVERS_ATTRIBUTE, solvers)
    return fn


def solvers_of(c: ir.Formula, ctx) -> dict[str, Solver]:
    """The solvers of an equation ``c`` by the variable they solve for (empty when ``c`` is
    not an equation between terms of variables, objects and arithmetic)."""
    if not isinstance(c, ir.Cmp) or c.op not in ("=", "==") or not (_plain(c.left) and _plain(c.right)):
        return {}
    out: dict[str, Solver] = {}
    for name in ir.free_vars(c):
        solve = _solver(c.left, c.right, name, ctx)
        if solve is not None:
            out[name] = solve
    return out


def _plain(t) -> bool:
    """A term of variables, literals, constructor objects and arithmetic only."""
    if isinstance(t, (ir.Var, ir.Lit)):
        return True
    if isinstance(t, (ir.Arith, ir.Obj)):
        return all(_plain(a) for a in t.args)
    return False


def _has(t, name: str) -> bool:
    return name in ir.free_vars(t)


def _solver(left, right, name: str, ctx) -> Solver | None:
    for a, b in ((left, right), (right, left)):
        if isinstance(a, ir.Var) and a.name == name and not _has(b, name):
            return _equal(b, ctx)
    names: dict[str, str] = {}
    lin_l, lin_r = _linear(left, name, names), _linear(right, name, names)
    if lin_l is None or lin_r is None:
        return None
    (al, bl), (ar, br) = lin_l, lin_r
    names.pop(name, None)
    reads = "".join(f"    {local} = env[{var!r}]\n" for var, local in names.items())
    guard = " and ".join(f"type({local}) is int" for local in names.values()) or "True"
    source = (f"def solve(env):\n{reads}    if not ({guard}):\n        return None\n"
              f"    a = {al} - {ar}\n    r = {br} - {bl}\n"
              "    if a == 0:\n        return None if r == 0 else []\n"
              "    return [r // a] if r % a == 0 else []\n")
    namespace: dict = {}
    exec(compile(source, "<equation>", "exec"), namespace)     # the source is ours alone
    return namespace["solve"]


def _equal(t, ctx) -> Solver:
    """``V = t`` with ``t`` free of V: the value of ``t``, whatever object it is."""
    fn = compile_term(t, ctx)

    def equal(env: dict) -> list | None:
        try:
            v = fn(env, 0)
        except GroundingError:       # a division by zero: the condition reports it, if tested
            return None
        return None if v is UNDEF or type(v) is Cases else [v]
    return equal


def _linear(t, name: str, names: dict[str, str]) -> tuple[str, str] | None:
    """``(a, b)``: Python sources with ``t == a * V + b`` over the integers for the variable
    ``V`` called ``name`` (the other variables' locals collected into ``names``); None when
    ``t`` is not of that form."""
    if not _has(t, name):
        src = int_source(t, names)
        return None if src is None else ("0", src)
    if isinstance(t, ir.Var):
        return "1", "0"
    if not isinstance(t, ir.Arith):
        return None
    parts = [_linear(x, name, names) for x in t.args]
    if any(p is None for p in parts):
        return None
    if t.op == "neg" and len(parts) == 1:
        (a, b), = parts                                 # type: ignore[misc]
        return f"(-{a})", f"(-{b})"
    if len(parts) != 2:
        return None
    (a1, b1), (a2, b2) = parts                          # type: ignore[misc]
    if t.op in ("+", "-"):
        return f"({a1} {t.op} {a2})", f"({b1} {t.op} {b2})"
    if t.op == "*":
        if not _has(t.args[0], name):                   # c * (a V + b)
            return f"({b1} * {a2})", f"({b1} * {b2})"
        if not _has(t.args[1], name):
            return f"({a1} * {b2})", f"({b1} * {b2})"
    return None
