"""What every statement resolver shares: one state, read in statement order.

CCALC gives a statement its meaning at the point where it stands (a macro applies from its
definition on, a variable from its declaration), so the resolvers do not each keep their own
tables: they work on the one state set up here, and :meth:`_Core._statement` hands each
statement, in order, to the ``_st_<Kind>`` method of whichever resolver owns that kind.
The helpers below are shared by several of them.
"""
from __future__ import annotations

from collections.abc import Callable

from cplus import ast, ir
from cplus.errors import Diagnostics, Location, ResolveError
from cplus.program import Program
from cplus.resolve.registry import Externals
from cplus.signature import USER_KINDS, NamedSort, Signature, SortExpr

Reader = Callable[[str, Location | None], ast.ParsedFile]
"""``read(path, loc)`` returns the parsed statements of a file or raises a CPlusError."""

_KIND_ALIASES = {k: k for k in USER_KINDS}


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

    def _file(self, parsed: ast.ParsedFile, key: str) -> None:
        self.included.add(key)
        self.program.files.append(parsed.source.path)  # type: ignore[attr-defined]
        self.stack.append(key)
        for stmt in parsed.statements:
            self._statement(stmt)
        self.stack.pop()

    def _statement(self, stmt: ast.Statement) -> None:
        handler = getattr(self, "_st_" + type(stmt).__name__)
        handler(stmt)


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
