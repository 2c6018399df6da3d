"""Resolved formulas and terms: names are bound to constants, objects and variables.

The resolver (:mod:`cplus.resolve`) turns :mod:`cplus.ast` expressions into these nodes
after macro expansion; the grounder compiles them into closures.  Terms evaluate to
objects (see :mod:`cplus.signature`); formulas to propositional formulas over atoms.
Annotations are evaluated, forward references quoted, as in :mod:`cplus.ast` (start-up).
"""

from collections.abc import Callable
from typing import NamedTuple

from cplus.errors import Location
from cplus.signature import ConstDecl, SortExpr

# ---------------------------------------------------------------------------- terms


class Lit(NamedTuple):
    """A ground object (or an integer)."""

    value: object


class Var(NamedTuple):
    name: str
    sort: SortExpr
    loc: Location


class Obj(NamedTuple):
    """A constructor object with non-ground arguments: ``cell(I+1)``."""

    name: str
    args: "tuple[Term, ...]"
    loc: Location


class Arith(NamedTuple):
    """``op`` in ``+ - * // mod neg abs min max``."""

    op: str
    args: "tuple[Term, ...]"
    loc: Location


class Cst(NamedTuple):
    """An occurrence of a constant; as a term it stands for the constant's value."""

    decl: ConstDecl
    args: "tuple[Term, ...]"
    loc: Location


class MaxStepT(NamedTuple):
    loc: Location


class StampT(NamedTuple):
    time: "Term"
    term: "Term"
    loc: Location


class Ext(NamedTuple):
    """A call of an external function (registry), evaluated at grounding time."""

    name: str
    fn: Callable[..., object]
    args: "tuple[Term, ...]"
    loc: Location


Term = Lit | Var | Obj | Arith | Cst | MaxStepT | StampT | Ext

# ---------------------------------------------------------------------------- formulas


class Truth(NamedTuple):
    value: bool


class Atom(NamedTuple):
    """``c(args)=value``; ``cst`` may be a variable over a constant kind (``A``)."""

    cst: Cst | Var
    value: Term
    loc: Location


class Cmp(NamedTuple):
    op: str
    left: Term
    right: Term
    loc: Location


class Not(NamedTuple):
    arg: "Formula"


class And(NamedTuple):
    items: "tuple[Formula, ...]"


class Or(NamedTuple):
    items: "tuple[Formula, ...]"


class Imp(NamedTuple):
    left: "Formula"
    right: "Formula"


class Iff(NamedTuple):
    left: "Formula"
    right: "Formula"


class Quant(NamedTuple):
    exists: bool
    var: Var
    body: "Formula"


class StampF(NamedTuple):
    time: Term
    body: "Formula"
    loc: Location


class ExtPred(NamedTuple):
    """An external predicate (``collision(X1,Y1,X2,Y2)``), decided at grounding time."""

    name: str
    fn: Callable[..., object]
    args: tuple[Term, ...]
    loc: Location


Formula = Truth | Atom | Cmp | Not | And | Or | Imp | Iff | Quant | StampF | ExtPred

TRUE = Truth(True)
FALSE = Truth(False)


def conj(items) -> Formula:
    flat: list = []
    for f in items:
        if isinstance(f, And):
            flat.extend(f.items)
        elif f == TRUE:
            continue
        else:
            flat.append(f)
    if not flat:
        return TRUE
    return flat[0] if len(flat) == 1 else And(tuple(flat))


def conjuncts(f: Formula | None) -> list:
    if f is None or f == TRUE:
        return []
    if isinstance(f, And):
        out: list = []
        for x in f.items:
            out.extend(conjuncts(x))
        return out
    return [f]


# ---------------------------------------------------------------------------- queries over the tree


def children(node) -> tuple:
    """The direct sub-terms and sub-formulas of a node (a quantifier's variable excluded)."""
    if isinstance(node, (Obj, Arith, Ext, ExtPred, Cst)):
        return node.args
    if isinstance(node, Atom):
        return (node.cst, node.value)
    if isinstance(node, (Cmp, Imp, Iff)):
        return (node.left, node.right)
    if isinstance(node, Not):
        return (node.arg,)
    if isinstance(node, (And, Or)):
        return node.items
    if isinstance(node, Quant):
        return (node.body,)
    if isinstance(node, StampF):
        return (node.time, node.body)
    if isinstance(node, StampT):
        return (node.time, node.term)
    return ()


def free_vars(node, bound: frozenset = frozenset()) -> dict[str, Var]:
    """Free variables of a term or formula, by name (first occurrence wins)."""
    out: dict[str, Var] = {}
    _free(node, bound, out)
    return out


def _free(node, bound, out) -> None:
    if isinstance(node, Var):
        if node.name not in bound:
            out.setdefault(node.name, node)
    elif isinstance(node, Quant):
        _free(node.body, bound | {node.var.name}, out)
    else:
        for child in children(node):
            _free(child, bound, out)


def constants_in(node, acc: list | None = None) -> list:
    """Every constant occurrence (:class:`Cst`, or a variable over a constant kind used as
    an atom); constants compared by name (``==``) do not count."""
    acc = [] if acc is None else acc
    if isinstance(node, Cst):
        acc.append(node)
    elif isinstance(node, Atom) and isinstance(node.cst, Var):
        acc.append(node.cst)
    elif isinstance(node, Cmp) and node.op in ("==", "\\=="):
        return acc
    for child in children(node):
        constants_in(child, acc)
    return acc


def mentions(node, kinds: tuple[type, ...]) -> bool:
    """Whether any node of the given types occurs (quantified variables included)."""
    if isinstance(node, kinds) or (isinstance(node, Quant) and isinstance(node.var, kinds)):
        return True
    return any(mentions(child, kinds) for child in children(node))
