"""What the resolver produces: basic causal laws, queries and display settings.

Every abbreviation of section C.2 of the language reference is expanded here into
:class:`BasicLaw` (``caused F if G after H`` with a time class) or :class:`IncrementLaw`;
laws implied by declarations (inertia, exogeneity of actions, attributes, defaults of
abnormalities) are left to the grounder, which knows each constant's kind.
"""
from __future__ import annotations

from cplus import ir
from cplus.errors import CPlusError, Diagnostics, Location
from cplus.record import Record
from cplus.signature import ConstDecl, Signature

__all__ = ["BasicLaw", "IncrementLaw", "QuerySpec", "Pattern", "Program", "StampedRule", "LAW_CLASSES",
           "SHOW_KEYWORDS"]

LAW_CLASSES = ("static", "action", "dynamic", "rigid")


class BasicLaw(Record):
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

    _fields = ("cls", "head", "body", "after", "where", "loc", "origin", "frame", "frame_cst")

    cls: str
    head: ir.Formula | None
    body: ir.Formula
    after: ir.Formula | None
    where: ir.Formula | None
    loc: Location
    origin: str
    frame: str | None
    frame_cst: ir.Cst | None

    def __init__(
            self,
            cls: str,
            head: ir.Formula | None,
            body: ir.Formula,
            after: ir.Formula | None,
            where: ir.Formula | None,
            loc: Location,
            origin: str,
            frame: str | None = None,
            frame_cst: ir.Cst | None = None) -> None:
        self.cls = cls
        self.head = head
        self.body = body
        self.after = after
        self.where = where
        self.loc = loc
        self.origin = origin
        self.frame = frame
        self.frame_cst = frame_cst


class IncrementLaw(Record):
    """``action increments target by amount if cond where where`` (decrements: negated)."""

    _fields = ("action", "target", "amount", "cond", "where", "decrement", "loc")

    action: ir.Formula
    target: ir.Cst
    amount: ir.Term
    cond: ir.Formula
    where: ir.Formula | None
    decrement: bool
    loc: Location

    def __init__(
            self,
            action: ir.Formula,
            target: ir.Cst,
            amount: ir.Term,
            cond: ir.Formula,
            where: ir.Formula | None,
            decrement: bool,
            loc: Location) -> None:
        self.action = action
        self.target = target
        self.amount = amount
        self.cond = cond
        self.where = where
        self.decrement = decrement
        self.loc = loc


class StampedRule(Record):
    """A causal rule of one step, from a time-stamped fact outside a query (``1: p if 0: q.``).

    CCALC reads such a fact as a causal rule of the steps it names; the completion is built
    per time class, so the rule reaches it through a hidden Boolean fluent ``aux`` (``cst``:
    its declaration applied to the head's free variables): the resolver adds the laws
    ``caused L if aux`` and ``exogenous aux``, and each horizon fixes ``aux`` at step ``step``
    to ``body`` (its variables that are not the head's read existentially; an atom stamped
    outside the horizon is false) and to false at every other step, so L is caused at that
    step exactly when the body holds.  ``cst`` None is a rule with head ``false``: no instance
    of ``body`` may hold."""

    _fields = ("cst", "step", "body", "loc")

    cst: ir.Cst | None
    step: int
    body: ir.Formula
    loc: Location

    def __init__(self, cst: ir.Cst | None, step: int, body: ir.Formula, loc: Location) -> None:
        self.cst = cst
        self.step = step
        self.body = body
        self.loc = loc


class QuerySpec(Record):
    """A query: ``lo..hi`` (hi None = infinity) and its items (universal free variables).

    An nmquery has ``rules`` instead (None for a query): ``(literal, body, loc)`` with
    ``literal`` None for ``false``; CCALC completes them on their own, over every atom, and
    the histories satisfy both that completion and the domain's.

    ``invariant`` is the ``invariant: F`` item of a ``maxstep :: any`` query (CCALC's proof
    that no plan of any length exists, :mod:`cplus.invariant`); such a query is never
    searched horizon by horizon, so it keeps ``lo..hi`` at ``0..infinity``.

    ``error`` is the located error of a query that could not be resolved (CCALC fails that
    query alone when it is asked, and answers the file's others): it holds its label, and
    :meth:`cplus.api.Domain.query` raises the error instead of returning it."""

    _fields = ("label", "lo", "hi", "items", "loc", "rules", "invariant", "error")

    label: str
    lo: int
    hi: int | None
    items: tuple[tuple[ir.Formula, Location], ...]
    loc: Location | None
    rules: tuple[tuple[ir.Formula | None, ir.Formula, Location], ...] | None
    invariant: tuple[ir.Formula, Location] | None
    error: CPlusError | None

    def __init__(
            self,
            label: str,
            lo: int,
            hi: int | None,
            items: tuple[tuple[ir.Formula, Location], ...],
            loc: Location | None,
            rules: tuple[tuple[ir.Formula | None, ir.Formula, Location], ...] | None = None,
            invariant: tuple[ir.Formula, Location] | None = None,
            error: CPlusError | None = None) -> None:
        self.label = label
        self.lo = lo
        self.hi = hi
        self.items = items
        self.loc = loc
        self.rules = rules
        self.invariant = invariant
        self.error = error

    @property
    def nm(self) -> bool:
        """Whether this is an nmquery (``:- nmquery``)."""
        return self.rules is not None


SHOW_KEYWORDS = ("positive", "negative", "all", "ab", "none")
"""CCALC's show specifications besides patterns (see :class:`cplus.output.Display`)."""


class Pattern(Record):
    """A show/hide pattern ``c(args)`` or ``c(args)=v`` (variables match any object), ``-c(args)``
    (the Boolean atom false), or ``c`` naming a constant without its arguments: ``decl`` is None
    and ``name`` matches every instance of every constant of that name (CCALC's ``show loc``).
    ``step`` (``t: c(args)``, CCALC's stamped specification) matches at that step only."""

    _fields = ("decl", "args", "value", "negated", "name", "step")

    decl: ConstDecl | None
    args: tuple[object, ...]       # ir.Var or a value
    value: object | None           # ir.Var, a value, or None (any value)
    negated: bool
    name: str
    step: int | None

    def __init__(self, decl: ConstDecl | None, args: tuple[object, ...], value: object | None,
                 negated: bool = False, name: str = "", step: int | None = None) -> None:
        self.decl = decl
        self.args = args
        self.value = value
        self.negated = negated
        self.name = name or (decl.name if decl is not None else "")
        self.step = step


class Program(Record):
    """A resolved domain description and its queries."""

    _fields = ("signature", "laws", "increments", "queries", "show", "hide", "hide_all", "show_given",
               "noconcurrency", "diagnostics", "files", "nmqueries", "facts")

    signature: Signature
    laws: list[BasicLaw]
    increments: list[IncrementLaw]
    queries: list[QuerySpec]
    show: list[Pattern | str]      # every `:- show` item in order: patterns and SHOW_KEYWORDS
    hide: list[Pattern]
    hide_all: bool
    show_given: bool
    noconcurrency: list[tuple[bool, Location]]
    diagnostics: Diagnostics
    files: list[str]
    nmqueries: list[QuerySpec]
    facts: list[StampedRule]
    """The rules of the time-stamped facts outside any query (``0: p.``): causal rules of the
    steps they name, as in CCALC (see :class:`StampedRule`)."""

    def __init__(
            self,
            signature: Signature,
            laws: list[BasicLaw] | None = None,
            increments: list[IncrementLaw] | None = None,
            queries: list[QuerySpec] | None = None,
            show: list[Pattern | str] | None = None,
            hide: list[Pattern] | None = None,
            hide_all: bool = False,
            show_given: bool = False,
            noconcurrency: list[tuple[bool, Location]] | None = None,
            diagnostics: Diagnostics | None = None,
            files: list[str] | None = None,
            nmqueries: list[QuerySpec] | None = None,
            facts: list[StampedRule] | None = None) -> None:
        self.signature = signature
        self.laws = [] if laws is None else laws
        self.increments = [] if increments is None else increments
        self.queries = [] if queries is None else queries
        self.show = [] if show is None else show
        self.hide = [] if hide is None else hide
        self.hide_all = hide_all
        self.show_given = show_given
        self.noconcurrency = [] if noconcurrency is None else noconcurrency
        self.diagnostics = Diagnostics() if diagnostics is None else diagnostics
        self.files = [] if files is None else files
        self.nmqueries = [] if nmqueries is None else nmqueries
        self.facts = [] if facts is None else facts
        self.scope: tuple[dict, dict] | None = None
        """The macros and variables in force at the end of the file (what the shell's
        ``show SPEC.`` reads its patterns with, :func:`cplus.resolve.show.resolve_show`)."""

    def query(self, label: str) -> QuerySpec | None:
        for q in self.queries:
            if q.label == label:
                return q
        return None

    def nmquery(self, label: str) -> QuerySpec | None:
        """The nmquery with this label (nmqueries have labels of their own: query 0 is not
        nmquery 0)."""
        for q in self.nmqueries:
            if q.label == label:
                return q
        return None
