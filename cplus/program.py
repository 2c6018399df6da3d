"""What the resolver produces: basic causal laws, queries and display settings.

Every abbreviation of section C.2 of the language reference is expanded here into
:class:`BasicLaw` (``caused F if G after H`` with a time class) or :class:`IncrementLaw`;
laws implied by declarations (inertia, exogeneity of actions, attributes, defaults of
abnormalities) are left to the grounder, which knows each constant's kind.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from cplus import ir
from cplus.errors import Diagnostics, Location
from cplus.signature import ConstDecl, Signature

__all__ = ["BasicLaw", "IncrementLaw", "QuerySpec", "Pattern", "Program", "LAW_CLASSES"]

LAW_CLASSES = ("static", "action", "dynamic", "rigid")


@dataclass(frozen=True)
class BasicLaw:
    """``caused head if body after after where where`` in one time class.

    * ``static``: head and body at every step 0..m;
    * ``action``: head (mentions actions) and body at every action step 0..m-1;
    * ``dynamic``: head and body at step i+1, ``after`` at step i, for 0 <= i < m;
    * ``rigid``: one unstamped rule.

    ``head`` None means ``false`` (a constraint).  ``frame`` expands one law per value v of
    the constant ``frame_cst``: ``"exogenous"`` (head c=v, body c=v & body),
    ``"inertial"`` (head c=v, body c=v, after c=v & after), ``"rigid"`` (false if
    -(c=v) after c=v).
    """

    cls: str
    head: ir.Formula | None
    body: ir.Formula
    after: ir.Formula | None
    where: ir.Formula | None
    loc: Location
    origin: str
    frame: str | None = None
    frame_cst: ir.Cst | None = None


@dataclass(frozen=True)
class IncrementLaw:
    """``action increments target by amount if cond where where`` (decrements: negated)."""

    action: ir.Formula
    target: ir.Cst
    amount: ir.Term
    cond: ir.Formula
    where: ir.Formula | None
    decrement: bool
    loc: Location


@dataclass(frozen=True)
class QuerySpec:
    """A query: ``lo..hi`` (hi None = infinity) and its items (universal free variables)."""

    label: str
    lo: int
    hi: int | None
    items: tuple[tuple[ir.Formula, Location], ...]
    loc: Location | None


@dataclass(frozen=True)
class Pattern:
    """A show/hide pattern ``c(args)`` or ``c(args)=v`` (variables match any object)."""

    decl: ConstDecl
    args: tuple[object, ...]       # ir.Var or a value
    value: object | None           # ir.Var, a value, or None (any value)
    negated: bool = False


@dataclass
class Program:
    """A resolved domain description and its queries."""

    signature: Signature
    laws: list[BasicLaw] = field(default_factory=list)
    increments: list[IncrementLaw] = field(default_factory=list)
    queries: list[QuerySpec] = field(default_factory=list)
    show: list[Pattern] = field(default_factory=list)
    hide: list[Pattern] = field(default_factory=list)
    hide_all: bool = False
    show_given: bool = False
    noconcurrency: list[tuple[bool, Location]] = field(default_factory=list)
    diagnostics: Diagnostics = field(default_factory=Diagnostics)
    files: list[str] = field(default_factory=list)

    def query(self, label: str) -> QuerySpec | None:
        for q in self.queries:
            if q.label == label:
                return q
        return None
