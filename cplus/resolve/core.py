"""What every statement resolver shares: one state, read in statement order, checked at the end.

CCALC gives a statement its meaning at the point where it stands (a macro applies from its
definition on, a variable from its declaration), so the resolvers do not each keep their own
tables: they work on the one state set up here, and :meth:`_Core._statement` hands each
statement, in order, to the ``_st_<Kind>`` method of whichever resolver owns that kind.
Some checks must wait for the end of the domain, because an object may be declared after the
law that names it and the sorts grow with every ``:- objects``: they close the same loop
(:meth:`_Core._finish`, :class:`_Validator`).  The helpers are shared by several resolvers.
"""
from __future__ import annotations

import os
from collections.abc import Callable

from cplus import ast, ir
from cplus.errors import CPlusError, Diagnostics, Location, ResolveError, SortError
from cplus.limits import MAX_GROUND_CONSTANTS, count
from cplus.program import Program
from cplus.resolve.registry import Externals
from cplus.signature import USER_KINDS, KindSort, NamedSort, Signature, SortExpr, StepSort

Reader = Callable[[str, Location | None], ast.ParsedFile]
"""``read(path, loc)`` returns the parsed statements of a file or raises a CPlusError."""

_KIND_ALIASES = {k: k for k in USER_KINDS}

_UNDECLARED = ("unknown constant or function", "unknown name")
"""How the messages for a name no declaration has introduced (yet) begin."""


class _Scope:
    """Variables visible in an expression: declared ones plus quantified ones."""

    __slots__ = ("local", "query", "law")

    def __init__(self, query: bool = False, law: str = "") -> None:
        self.local: dict[str, ir.Var] = {}
        self.query = query
        self.law = law

    def with_var(self, var: ir.Var) -> _Scope:
        s = _Scope(self.query, self.law)
        s.local = dict(self.local)
        s.local[var.name] = var
        return s


class _Core:
    """The state of one resolution; each statement resolver is a mixin over it."""

    def __init__(self, read: Reader, externals: Externals, diagnostics: Diagnostics) -> None:
        self.read = read
        self.externals = externals
        self.sig = Signature()
        self.program = Program(self.sig, diagnostics=diagnostics)
        self.diag = diagnostics
        self.macros: dict[tuple[str, int], ast.MacroDef] = {}
        self.measured: dict[tuple, tuple[int, int]] = {}   # (macro, argument sizes) -> (size, depth)
        self.macro_seen = False    # the last measured expression calls a macro
        self.expanded = 0          # nodes produced by expanding macros so far
        self.variables: dict[str, ir.Var] = {}
        self.objects: dict[str, Location | None] = {"true": None, "false": None, "none": None}
        self.included: set[str] = set()
        self.stack: list[str] = []
        self.const_order = 0
        self.deferred: list[tuple[ast.Law, dict, dict]] = []
        self.defaulted: set[tuple[str, int]] = set()   # constants an `unless` gave `default -ab`
        self.stamped_later: list[Location] = []        # facts with a head stamped after step 0
        self.patterns_to_check: list = []              # show/hide patterns, checked at the end

    def run(self, main: ast.ParsedFile) -> None:
        path = main.source.path  # type: ignore[attr-defined]
        self._file(main, os.path.abspath(path) if not path.startswith("<") else path)
        self._finish()

    def _file(self, parsed: ast.ParsedFile, key: str) -> None:
        self.included.add(key)
        self.program.files.append(parsed.source.path)  # type: ignore[attr-defined]
        self.stack.append(key)
        for stmt in parsed.statements:
            self._statement(stmt)
        self.stack.pop()

    def _statement(self, stmt: ast.Statement) -> None:
        handler = getattr(self, "_st_" + type(stmt).__name__)
        try:
            handler(stmt)
        except CPlusError as exc:
            if not (isinstance(stmt, ast.Law) and isinstance(exc, ResolveError)
                    and exc.message.startswith(_UNDECLARED)):
                self._deferred_laws()       # a law put off before this statement is reported first
                raise
            # CCALC grounds laws after reading the whole file, so a law may name a constant
            # declared further on (its traffic examples do): try it again at the end, with
            # the macros and variables it sees here
            self.deferred.append((stmt, dict(self.macros), dict(self.variables)))

    def _deferred_laws(self) -> None:
        """The laws that named a constant not yet declared, now that every one is."""
        macros, variables = self.macros, self.variables
        deferred, self.deferred = self.deferred, []
        try:
            for stmt, seen_macros, seen_variables in deferred:
                self.macros, self.variables = seen_macros, seen_variables
                self._st_Law(stmt)  # type: ignore[attr-defined]
        finally:
            self.macros, self.variables = macros, variables

    def _check_ground_size(self) -> None:
        """Refuse, before enumerating them, more ground constants than MAX_GROUND_CONSTANTS."""
        total = 0
        for d in self.sig.constants.values():
            sizes = [len(self.sig.objects_of(s)) for s in d.argsorts]
            n = 1
            for k in sizes:
                n *= k
            total += n
            if total > MAX_GROUND_CONSTANTS:
                product = " x ".join(f"{k:,}" for k in sizes)
                raise SortError(f"'{d.name}/{d.arity}' has {count(n)} ground instances ({product})"
                                + ("" if n == total else f", {count(total)} with the constants before it")
                                + f"; a domain may have at most {count(MAX_GROUND_CONSTANTS)}", d.loc)

    def _finish(self) -> None:
        self._deferred_laws()
        has_additive = any(d.kind in ("additiveFluent", "additiveAction") for d in self.sig.constants.values())
        if has_additive and self.sig.max_additive is None:
            d = next(d for d in self.sig.constants.values() if d.kind in ("additiveFluent", "additiveAction"))
            raise SortError("additive constants need ':- maxAdditive :: N.'", d.loc)
        self._check_ground_size()
        self._ccalc_differences()
        self.sig.finalize()
        self._check_patterns()  # type: ignore[attr-defined]
        self.program.scope = (self.macros, self.variables)
        _Validator(self.sig).run(self.program)


    def _ccalc_differences(self) -> None:
        """Warnings where cplus keeps, on purpose, a meaning other than CCALC's for the same
        text (docs/language.md, section 10)."""
        if any(law.cls == "dynamic" for law in self.program.laws):
            for loc in self.stamped_later:
                self.diag.warn("a fact stamped after step 0 is a causal rule of that step only here (as in "
                               "CCALC's history mode); CCALC in transition mode, for a domain with dynamic "
                               "laws, grounds it over steps 0 and 1 and repeats a rule of step 1 at every "
                               "later step", loc)
        for d in self.sig.constants.values():
            if d.kind == "abAction" and not d.abnormal:
                self.diag.warn(f"'{d.name}' is declared abAction but no 'unless' names it: as in CCALC it gets "
                               "no default (its value must be caused, as a plain action's); it is printed "
                               "among the actions here, where CCALC prints it in the state line or not at all",
                               d.loc)


def _no_sort_here(e) -> None:
    """A range or a star sort where a term or formula is expected: say where they belong."""
    if isinstance(e, ast.Range):
        raise ResolveError("a range 'lo..hi' may only occur in declarations (objects, the sorts of "
                           "constants and variables, macros used there) and in 'maxstep ::'", e.loc)
    if isinstance(e, ast.SortRef):
        raise ResolveError(f"the sort '{e.name}*' may only occur in declarations", e.loc)


def _is_boolean(sort: SortExpr) -> bool:
    return isinstance(sort, NamedSort) and sort.name == "boolean" and not sort.star


def _show(v) -> str:
    from cplus.signature import render_value
    return render_value(v)


def _ast_text(e: ast.Expr) -> str:
    if isinstance(e, ast.Num):
        return str(e.value)
    if isinstance(e, ast.Name):
        return e.name + (f"({','.join(_ast_text(a) for a in e.args)})" if e.args else "")
    return "?"


class _Validator:
    """Checks that need the final object sets: literal arguments and values in their sorts."""

    def __init__(self, sig: Signature) -> None:
        self.sig = sig
        self.disjoint: dict[tuple, bool] = {}

    def run(self, program: Program) -> None:
        for law in program.laws:
            for part in (law.head, law.body, law.after, law.where):
                if part is not None:
                    self.walk(part)
        for inc in program.increments:
            self.walk(inc.action)
            self.walk(inc.cond)
            self.walk(inc.target)
        for q in program.queries:
            for f, _ in q.items:
                self.walk(f)
        for q in program.nmqueries:
            for head, body, _ in q.rules or ():
                self.walk(body)
                if head is not None:
                    self.walk(head)

    def walk(self, node) -> None:
        if isinstance(node, ir.Cst):
            for sort, a in zip(node.decl.argsorts, node.args):
                if isinstance(a, ir.Lit) and not isinstance(sort, (StepSort,)) and not self.sig.contains(sort, a.value):
                    raise SortError(f"'{_show(a.value)}' is not an object of sort '{sort}' "
                                    f"(argument of '{node.decl.name}')", node.loc)
                if isinstance(a, ir.Var) and not isinstance(a.sort, (StepSort, KindSort)) and \
                        not isinstance(sort, StepSort):
                    if self._disjoint(a.sort, sort):
                        raise SortError(f"variable {a.name} of sort '{a.sort}' can never be an argument of "
                                        f"sort '{sort}' of '{node.decl.name}'", a.loc)
        elif isinstance(node, ir.Atom) and isinstance(node.cst, ir.Cst) and isinstance(node.value, ir.Lit):
            dom = self.sig.objects_of(node.cst.decl.domain)
            v = node.value.value
            if v not in dom and not (v == "none" and node.cst.decl.kind in ("attribute", "abAction")):
                raise SortError(f"'{_show(v)}' is not in the domain {node.cst.decl.domain} of "
                                f"'{node.cst.decl.name}'", node.loc)
        for child in ir.children(node):
            self.walk(child)

    def _disjoint(self, var_sort: SortExpr, arg_sort: SortExpr) -> bool:
        key = (var_sort, arg_sort)
        known = self.disjoint.get(key)
        if known is None:
            mine = self.sig.objects_of(var_sort)
            known = self.disjoint[key] = bool(mine) and not set(mine) & set(self.sig.objects_of(arg_sort))
        return known
