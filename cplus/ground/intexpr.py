"""Integer arithmetic over variables as one Python function per term or comparison.

The general closures of :mod:`cplus.ground.compile` call one function per node of a term
and check every operand for constants and undefined values: ``where P + S * D =< 300``
costs six calls per binding, and an arithmetic-heavy law has tens of thousands of
bindings (car-300: 16,000 rules, 30,000 comparisons).  A term made only of variables,
integer literals and ``+ - *`` (and unary minus) is compiled instead to a single
expression, ``(env['P'] + (env['S'] * env['D'])) <= 300``, evaluated when every variable
holds an integer; otherwise (an object of a mixed sort) the general closure answers, so
the results are the same.  These operators cannot fail on integers, and Python's integers
are exact, as the closures' are.
"""
from __future__ import annotations

from collections.abc import Callable

from cplus import ir

__all__ = ["int_term", "int_comparison", "int_source"]

_OPS = {"+": "+", "-": "-", "*": "*"}
_RELATIONS = {"<": "<", ">": ">", "=<": "<=", ">=": ">=", "=": "==", "==": "=="}


def int_source(t, names: dict[str, str]) -> str | None:
    """Python source of a term over the variables (collected into ``names``), or None when
    the term has anything else in it."""
    if isinstance(t, ir.Lit):
        return f"({t.value!r})" if type(t.value) is int else None
    if isinstance(t, ir.Var):
        return names.setdefault(t.name, f"v{len(names)}")
    if isinstance(t, ir.Arith):
        parts = [int_source(a, names) for a in t.args]
        if any(p is None for p in parts):
            return None
        if t.op == "neg" and len(parts) == 1:
            return f"(-{parts[0]})"
        if t.op in _OPS and len(parts) == 2:
            return f"({parts[0]} {_OPS[t.op]} {parts[1]})"
    return None


def _compile(expr: str, names: dict[str, str], general: Callable) -> Callable:
    """``fn(env, time)``: ``expr`` when every variable holds an integer, else ``general``."""
    reads = "".join(f"    {local} = env[{name!r}]\n" for name, local in names.items())
    guard = " and ".join(f"type({local}) is int" for local in names.values()) or "True"
    source = f"def fn(env, time):\n{reads}    if {guard}:\n        return {expr}\n    return general(env, time)\n"
    namespace: dict = {"general": general}
    exec(compile(source, "<integer arithmetic>", "exec"), namespace)     # the source is ours alone
    return namespace["fn"]


def int_term(t: ir.Arith, general: Callable) -> Callable:
    """The term as one function, or ``general`` when it is not plain integer arithmetic."""
    names: dict[str, str] = {}
    expr = int_source(t, names)
    return general if expr is None else _compile(expr, names, general)


def int_comparison(f: ir.Cmp, general: Callable) -> Callable:
    """The comparison as one function when both sides are plain integer arithmetic (variables
    holding objects, which compare in the standard order, go to ``general``), else
    ``general``."""
    rel = _RELATIONS.get(f.op)
    if rel is None:
        return general
    names: dict[str, str] = {}
    left, right = int_source(f.left, names), int_source(f.right, names)
    if left is None or right is None:
        return general
    return _compile(f"{left} {rel} {right}", names, general)
