"""``:- show`` and ``:- hide``: which atoms a plan prints.

Patterns are not formulas: an argument may be a variable that matches anything, and no atom
is built, so they are resolved on their own, down to a declaration and arguments that are
objects or variables.
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import ResolveError
from cplus.program import Pattern
from cplus.resolve.core import _Scope
from cplus.resolve.terms import _Terms


class _Show(_Terms):
    def _st_ShowHide(self, stmt: ast.ShowHide) -> None:
        if stmt.all_:
            self.program.hide_all = stmt.hide
        pats = [self._pattern(p) for p in stmt.patterns]
        if stmt.hide:
            self.program.hide.extend(pats)
        else:
            self.program.show.extend(pats)
            self.program.show_given = True

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
            raise ResolveError(f"unknown constant '{e.name}/{len(e.args)}' in show/hide", e.loc)
        return Pattern(decl, tuple(self._pattern_arg(a) for a in e.args), value, negated)

    def _pattern_arg(self, a: ast.Expr):
        t = self._term(a, _Scope())
        if isinstance(t, (ir.Lit, ir.Var)):
            return t if isinstance(t, ir.Var) else t.value
        raise ResolveError("show/hide arguments are objects or variables", a.loc)
