"""``:- show`` and ``:- hide``: which atoms a plan prints.

Patterns are not formulas: an argument may be a variable that matches anything, and no atom
is built, so they are resolved on their own, down to a declaration and arguments that are
objects or variables.  A show statement may also hold CCALC's specifications ``positive``,
``negative``, ``all``, ``ab`` and ``none`` (their meaning is :class:`cplus.output.Display`'s).
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import ResolveError
from cplus.program import SHOW_KEYWORDS, Pattern
from cplus.resolve.core import _Scope
from cplus.resolve.terms import _Terms


class _Show(_Terms):
    def _st_ShowHide(self, stmt: ast.ShowHide) -> None:
        if stmt.hide:
            if stmt.all_:
                self.program.hide_all = True
            self.program.hide.extend(self._pattern(p) for p in stmt.patterns)
            return
        specs: list[Pattern | str] = ["all"] if stmt.all_ else []
        for p in stmt.patterns:
            keyword = self._keyword(p)
            specs.append(keyword if keyword is not None else self._pattern(p))
        self.program.show.extend(specs)
        self.program.show_given = True

    def _keyword(self, e: ast.Expr) -> str | None:
        """``positive``, ``negative``, ``ab`` or ``none`` as a show specification.  As in CCALC,
        the word is the keyword even when a constant has that name (warned: write the
        constant with its arguments or a value, ``positive=V``, to mean it)."""
        if not (isinstance(e, ast.Name) and not e.args and e.name in SHOW_KEYWORDS):
            return None
        if self.sig.constants_named(e.name):
            self.diag.warn(f"show specification '{e.name}' is ambiguous: it is a keyword of ':- show', so it does not "
                           f"name the constant '{e.name}' (write '{e.name}=V' or give its arguments for the "
                           "constant)", e.loc)
        return e.name

    def _pattern(self, e: ast.Expr) -> Pattern:
        e = self._expand(e)
        negated = False
        if isinstance(e, ast.Unary) and e.op == "not":
            negated, e = True, e.arg
        value = None
        if isinstance(e, ast.Binary) and e.op == "=":
            value = self._pattern_arg(e.right)
            e = e.left
        if not isinstance(e, ast.Name):
            raise ResolveError("a show/hide pattern is an atom 'c(args)' or 'c(args)=v'", e.loc)
        decl = self.sig.lookup(e.name, len(e.args))
        if decl is None:
            if not e.args and self.sig.constants_named(e.name):   # `show loc`: every instance of loc
                return Pattern(None, (), value, negated, e.name)
            raise ResolveError(f"unknown constant '{e.name}/{len(e.args)}' in show/hide", e.loc)
        return Pattern(decl, tuple(self._pattern_arg(a) for a in e.args), value, negated)

    def _pattern_arg(self, a: ast.Expr):
        t = self._term(a, _Scope())
        if isinstance(t, (ir.Lit, ir.Var)):
            return t if isinstance(t, ir.Var) else t.value
        raise ResolveError("show/hide arguments are objects or variables", a.loc)
