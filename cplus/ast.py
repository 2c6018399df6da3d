"""The syntax tree of C+ statements, as written (before names are resolved).

Formulas and terms share one expression type because CCALC's grammar does too: whether
``p(X)`` is an atom, an object or a macro call is only known once declarations are read
(:mod:`cplus.resolve`).  Every node carries its :class:`~cplus.errors.Location`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Union

from cplus.errors import Location

# ----------------------------------------------------------------------- expressions


@dataclass(frozen=True, slots=True)
class Num:
    loc: Location
    value: int


@dataclass(frozen=True, slots=True)
class Name:
    """An identifier, possibly applied to arguments: ``p``, ``X``, ``move(B,table)``."""

    loc: Location
    name: str
    args: tuple["Expr", ...] = ()


@dataclass(frozen=True, slots=True)
class Param:
    """A macro parameter ``#k`` (only inside macro bodies)."""

    loc: Location
    index: int


@dataclass(frozen=True, slots=True)
class MaxStep:
    loc: Location


@dataclass(frozen=True, slots=True)
class Unary:
    """``op`` is ``"not"`` (formula negation), ``"-"`` (unary minus) or ``"abs"``."""

    loc: Location
    op: str
    arg: "Expr"


@dataclass(frozen=True, slots=True)
class Binary:
    """Arithmetic (``+ - * // mod``), comparisons (``= \\= == < ... @>=``) and
    connectives (``& , && ++ || ->> <->>``)."""

    loc: Location
    op: str
    left: "Expr"
    right: "Expr"


@dataclass(frozen=True, slots=True)
class QuantVar:
    loc: Location
    exists: bool
    name: str


@dataclass(frozen=True, slots=True)
class Quant:
    """``[\\/X /\\Y | body]``: variables bind left to right."""

    loc: Location
    vars: tuple[QuantVar, ...]
    body: "Expr"


@dataclass(frozen=True, slots=True)
class Stamp:
    """``time: body`` (queries only)."""

    loc: Location
    time: "Expr"
    body: "Expr"


@dataclass(frozen=True, slots=True)
class Range:
    """``lo..hi`` in declarations."""

    loc: Location
    lo: "Expr"
    hi: "Expr"


Expr = Union[Num, Name, Param, MaxStep, Unary, Binary, Quant, Stamp, Range]

ARITH_OPS = frozenset({"+", "-", "*", "//", "mod"})
COMPARE_OPS = frozenset({"=", "\\=", "==", "<", ">", "=<", ">=", "@<", "@>", "@=<", "@>="})
CONNECTIVES = frozenset({"&", ",", "&&", "++", "||", "->>", "<->>"})

# ----------------------------------------------------------------------- sorts


@dataclass(frozen=True, slots=True)
class SortRef:
    """A sort written in a declaration: ``loc``, ``disk*`` / ``disk+none`` (star)."""

    loc: Location
    name: str
    star: bool = False


SortSpec = Union[SortRef, Range]

# ----------------------------------------------------------------------- statements


@dataclass(frozen=True, slots=True)
class SortDecl:
    loc: Location
    name: str
    parent: str | None


@dataclass(frozen=True, slots=True)
class Sorts:
    loc: Location
    decls: tuple[SortDecl, ...]


@dataclass(frozen=True, slots=True)
class ObjectItem:
    loc: Location
    terms: tuple[Expr, ...]
    sort: str
    sort_loc: Location


@dataclass(frozen=True, slots=True)
class Objects:
    loc: Location
    items: tuple[ObjectItem, ...]


@dataclass(frozen=True, slots=True)
class ConstName:
    loc: Location
    name: str
    args: tuple[SortSpec, ...]


@dataclass(frozen=True, slots=True)
class ConstSpec:
    """``kind`` is None for a rigid constant written ``c :: D``; ``parent`` is set for
    attributes (``attribute(D) of parent``)."""

    loc: Location
    kind: str | None
    domain: SortSpec | None
    parent: ConstName | None = None


@dataclass(frozen=True, slots=True)
class ConstantItem:
    loc: Location
    names: tuple[ConstName, ...]
    spec: ConstSpec


@dataclass(frozen=True, slots=True)
class Constants:
    loc: Location
    items: tuple[ConstantItem, ...]


@dataclass(frozen=True, slots=True)
class VariableItem:
    loc: Location
    names: tuple[tuple[str, Location], ...]
    sort: SortSpec


@dataclass(frozen=True, slots=True)
class Variables:
    loc: Location
    items: tuple[VariableItem, ...]


@dataclass(frozen=True, slots=True)
class MacroDef:
    loc: Location
    name: str
    arity: int
    body: Expr


@dataclass(frozen=True, slots=True)
class Macros:
    loc: Location
    items: tuple[MacroDef, ...]


@dataclass(frozen=True, slots=True)
class Include:
    loc: Location
    paths: tuple[tuple[str, Location], ...]


@dataclass(frozen=True, slots=True)
class ShowHide:
    """``patterns`` holds atom patterns; ``all_`` is true for ``show all``/``hide all``."""

    loc: Location
    hide: bool
    all_: bool
    patterns: tuple[Expr, ...]


@dataclass(frozen=True, slots=True)
class QueryLabel:
    loc: Location
    label: str


@dataclass(frozen=True, slots=True)
class QueryMaxstep:
    """``maxstep :: lo`` (hi is lo), ``lo..hi``, or ``lo..infinity`` (hi None)."""

    loc: Location
    lo: Expr
    hi: Expr | None
    exact: bool


@dataclass(frozen=True, slots=True)
class QueryItem:
    loc: Location
    formula: Expr


@dataclass(frozen=True, slots=True)
class Query:
    loc: Location
    items: tuple[QueryLabel | QueryMaxstep | QueryItem, ...]


@dataclass(frozen=True, slots=True)
class MaxAdditive:
    loc: Location
    value: Expr


@dataclass(frozen=True, slots=True)
class NoConcurrency:
    loc: Location
    strong: bool


@dataclass(frozen=True, slots=True)
class Law:
    """One causal law as written.

    ``kind`` is one of ``caused`` (also facts and ``possibly caused`` -> ``default``),
    ``causes``, ``may_cause``, ``increments``, ``nonexecutable``, ``default``,
    ``exogenous``, ``inertial``, ``constraint``, ``always``, ``rigid``, ``never``, ``fact``.
    ``head`` is the caused formula (or the constant list of exogenous/inertial/rigid, the
    formula of constraint/always/never/nonexecutable); ``action`` is the action formula of
    causes/may cause/increments; ``target`` and ``amount`` belong to increments.
    """

    loc: Location
    kind: str
    head: Expr | None
    action: Expr | None = None
    if_: Expr | None = None
    after: Expr | None = None
    unless: Expr | None = None
    where: Expr | None = None
    amount: Expr | None = None
    decrement: bool = False


Statement = Union[Sorts, Objects, Constants, Variables, Macros, Include, ShowHide, Query,
                  MaxAdditive, NoConcurrency, Law]


@dataclass(frozen=True, slots=True)
class ParsedFile:
    """The statements of one file, in order (includes not yet followed)."""

    source: object
    statements: tuple[Statement, ...]
