"""The syntax tree of C+ statements, as written (before names are resolved).

Formulas and terms share one expression type because CCALC's grammar does too: whether
``p(X)`` is an atom, an object or a macro call is only known once declarations are read
(:mod:`cplus.resolve`).  Every node carries its :class:`~cplus.errors.Location`.  Nodes are named tuples: immutable,
hashable, and cheap to define (start-up time counts for a command-line planner).  For the
same reason the module does without ``from __future__ import annotations``: ``NamedTuple``
turns a string annotation into a ``ForwardRef``, which compiles it (the 146 fields of this
module and :mod:`cplus.ir` took 9.4 ms to import that way, 7.2 ms now); only the forward
references are strings.
"""

from typing import NamedTuple

from cplus.errors import Location

# ----------------------------------------------------------------------- expressions


class Num(NamedTuple):
    loc: Location
    value: int


class Name(NamedTuple):
    """An identifier, possibly applied to arguments: ``p``, ``X``, ``move(B,table)``."""

    loc: Location
    name: str
    args: "tuple[Expr, ...]" = ()


class Param(NamedTuple):
    """A macro parameter ``#k`` (only inside macro bodies)."""

    loc: Location
    index: int  # type: ignore[assignment]


class MaxStep(NamedTuple):
    loc: Location


class Unary(NamedTuple):
    """``op`` is ``"not"`` (formula negation), ``"-"`` (unary minus), ``"abs"``, or ``"cneg"``:
    the ``-`` of ``-c=v`` written without parentheses, which CCALC reads as ``(-c)=v`` (the
    resolver warns, or refuses it for a constant that is not an integer, as CCALC does)."""

    loc: Location
    op: str
    arg: "Expr"


class Binary(NamedTuple):
    """Arithmetic (``+ - * // mod``), comparisons (``= \\= == < ... @>=``) and
    connectives (``& , && ++ || ->> <->>``)."""

    loc: Location
    op: str
    left: "Expr"
    right: "Expr"


class QuantVar(NamedTuple):
    loc: Location
    exists: bool
    name: str


class Quant(NamedTuple):
    """``[\\/X /\\Y | body]``: variables bind left to right."""

    loc: Location
    vars: tuple[QuantVar, ...]
    body: "Expr"


class Stamp(NamedTuple):
    """``time: body`` (queries only)."""

    loc: Location
    time: "Expr"
    body: "Expr"


class Range(NamedTuple):
    """``lo..hi`` (integer expressions): in objects, sorts, macro bodies and maxstep only."""

    loc: Location
    lo: "Expr"
    hi: "Expr"


class SortRef(NamedTuple):
    """A sort written in a declaration: ``loc``, ``disk*`` / ``disk+none`` (star)."""

    loc: Location
    name: str
    star: bool = False


Expr = Num | Name | Param | MaxStep | Unary | Binary | Quant | Stamp | Range | SortRef
"""A sort reference is an expression only as a constructor argument or a kind's domain
(``inertialFluent(disk*)``); the resolver rejects it elsewhere."""

ARITH_OPS = frozenset({"+", "-", "*", "//", "mod"})
COMPARE_OPS = frozenset({"=", "\\=", "==", "<", ">", "=<", ">=", "@<", "@>", "@=<", "@>="})

# ----------------------------------------------------------------------- sorts


SortSpec = SortRef | Range | Expr
"""A sort in a declaration: a name, ``s*``, a range, or a macro call that expands to one."""

# ----------------------------------------------------------------------- statements


class SortDecl(NamedTuple):
    loc: Location
    name: str
    parent: str | None


class Sorts(NamedTuple):
    loc: Location
    decls: tuple[SortDecl, ...]


class ObjectItem(NamedTuple):
    loc: Location
    terms: tuple[Expr, ...]
    sort: str
    sort_loc: Location


class Objects(NamedTuple):
    loc: Location
    items: tuple[ObjectItem, ...]


class ConstName(NamedTuple):
    loc: Location
    name: str
    args: tuple[SortSpec, ...]


class ConstSpec(NamedTuple):
    """``kind`` is None for a rigid constant written ``c :: D``; ``parent`` is set for
    attributes (``attribute(D) of parent``)."""

    loc: Location
    kind: str | None
    domain: SortSpec | None
    parent: ConstName | None = None


class ConstantItem(NamedTuple):
    loc: Location
    names: tuple[ConstName, ...]
    spec: ConstSpec


class Constants(NamedTuple):
    loc: Location
    items: tuple[ConstantItem, ...]


class VariableItem(NamedTuple):
    loc: Location
    names: tuple[tuple[str, Location], ...]
    sort: SortSpec


class Variables(NamedTuple):
    loc: Location
    items: tuple[VariableItem, ...]


class MacroDef(NamedTuple):
    loc: Location
    name: str
    arity: int
    body: Expr


class Macros(NamedTuple):
    loc: Location
    items: tuple[MacroDef, ...]


class Include(NamedTuple):
    loc: Location
    paths: tuple[tuple[str, Location], ...]


class ShowHide(NamedTuple):
    """``patterns`` holds atom patterns; ``all_`` is true for ``show all``/``hide all``."""

    loc: Location
    hide: bool
    all_: bool
    patterns: tuple[Expr, ...]


class QueryLabel(NamedTuple):
    """``label :: L``: a name, an integer, or a macro or integer expression giving one."""

    loc: Location
    label: Expr


class QueryMaxstep(NamedTuple):
    """``maxstep :: lo`` (hi is lo), ``lo..hi``, or ``lo..infinity`` (hi None)."""

    loc: Location
    lo: Expr
    hi: Expr | None


class QueryItem(NamedTuple):
    loc: Location
    formula: Expr


class QueryRule(NamedTuple):
    """A rule of an nmquery: ``caused head if body`` (``default``: ``caused head if head & body``);
    a bare formula F is ``caused F``.  ``body`` None means ``true``."""

    loc: Location
    head: Expr
    body: Expr | None
    default: bool


class Query(NamedTuple):
    """``:- query`` (``nm`` False: its items are formulas) or ``:- nmquery`` (``nm`` True: its
    items are :class:`QueryRule`, completed on their own)."""

    loc: Location
    items: tuple[QueryLabel | QueryMaxstep | QueryItem | QueryRule, ...]
    nm: bool = False


class MaxAdditive(NamedTuple):
    loc: Location
    value: Expr


class NoConcurrency(NamedTuple):
    loc: Location
    strong: bool


class Law(NamedTuple):
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


Statement = (
    Sorts
    | Objects
    | Constants
    | Variables
    | Macros
    | Include
    | ShowHide
    | Query
    | MaxAdditive
    | NoConcurrency
    | Law
)


class ParsedFile(NamedTuple):
    """The statements of one file, in order (includes not yet followed)."""

    source: object
    statements: tuple[Statement, ...]
