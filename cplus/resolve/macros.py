"""Macros: ``:- macros`` statements and their expansion.

CCALC expands a macro on the syntax tree at every use after its definition, before anything
looks at the expression, so every other resolver builds on this one.  The limits on expansion
(the size, the depth, the total for the domain) are kept here, where the nodes are produced.
"""
from __future__ import annotations

from cplus import ast
from cplus.errors import ResolveError
from cplus.limits import MAX_EXPANDED, MAX_EXPANSION, MAX_NESTING, count
from cplus.resolve.core import _Core


class _Macros(_Core):
    def _st_Macros(self, stmt: ast.Macros) -> None:
        for m in stmt.items:
            self.macros[(m.name, m.arity)] = m
        self.measured.clear()

    def _expand(self, e: ast.Expr, stack: tuple = ()) -> ast.Expr:
        """``e`` with every macro replaced by its body (arguments substituted).  At the top call
        the size and depth of the result are estimated first, so that a macro that doubles at
        each level is refused with its size instead of being built."""
        if not stack and self.macros:
            self.macro_seen = False
            try:
                size, depth = self._measure(e, (), 0, ())
            except _TooDeep:
                depth = MAX_NESTING + 1
            if depth > MAX_NESTING:
                raise ResolveError(f"expanding the macros here nests expressions (or macro calls) more than "
                                   f"{MAX_NESTING} levels deep", e.loc)
            if size > MAX_EXPANSION:
                raise ResolveError(f"expanding the macros here gives an expression of {count(size)} nodes; "
                                   f"the limit is {count(MAX_EXPANSION)}", e.loc)
            if self.macro_seen:
                self.expanded += size
                if self.expanded > MAX_EXPANDED:
                    raise ResolveError(f"macro expansion has produced more than {count(MAX_EXPANDED)} nodes "
                                       "in this domain, the limit (this is where it went over)", e.loc)
        return self._expand_x(e, stack)

    def _measure(self, e: ast.Expr, params: tuple, level: int, active: tuple) -> tuple[int, int]:
        """(nodes, depth) of ``e`` after macro expansion, computed without expanding: each macro
        is measured once per distinct measure of its arguments.  ``level`` is the depth in the
        expansion and ``active`` the macros being measured (a recursive one measures as a single
        node: its expansion reports it); past MAX_NESTING of either the walk stops with
        :class:`_TooDeep`, so this recursion is bounded."""
        if level > MAX_NESTING or len(active) > MAX_NESTING:
            raise _TooDeep
        if isinstance(e, ast.Param):
            return params[e.index - 1] if e.index <= len(params) else (1, 1)
        if isinstance(e, ast.Name):
            args = tuple(self._measure(a, params, level + 1, active) for a in e.args)
            name = (e.name, len(e.args))
            m = self.macros.get(name)
            if m is not None:
                self.macro_seen = True
            if m is None or name in active:
                return 1 + sum(a[0] for a in args), 1 + max((a[1] for a in args), default=0)
            key = (name, args)
            known = self.measured.get(key)
            if known is None:
                known = self.measured[key] = self._measure(m.body, args, level, active + (name,))
            return known
        parts: tuple = ()
        if isinstance(e, ast.Unary):
            parts = (e.arg,)
        elif isinstance(e, ast.Binary):
            parts = (e.left, e.right)
        elif isinstance(e, (ast.Quant,)):
            parts = (e.body,)
        elif isinstance(e, ast.Stamp):
            parts = (e.time, e.body)
        elif isinstance(e, ast.Range):
            parts = (e.lo, e.hi)
        sizes = [self._measure(p, params, level + 1, active) for p in parts]
        return 1 + sum(x[0] for x in sizes), 1 + max((x[1] for x in sizes), default=0)

    def _expand_x(self, e: ast.Expr, stack: tuple) -> ast.Expr:
        if isinstance(e, ast.Name):
            key = (e.name, len(e.args))
            args = tuple(self._expand_x(a, stack) for a in e.args)
            m = self.macros.get(key)
            if m is None:
                return ast.Name(e.loc, e.name, args) if args != e.args else e
            if key in stack:
                raise ResolveError(f"recursive macro '{e.name}/{len(e.args)}'", e.loc)
            body = self._expand_x(m.body, stack + (key,))
            return _substitute(body, args) if args else body
        if isinstance(e, ast.Unary):
            a = self._expand_x(e.arg, stack)
            return e if a is e.arg else ast.Unary(e.loc, e.op, a)
        if isinstance(e, ast.Binary):
            left, right = self._expand_x(e.left, stack), self._expand_x(e.right, stack)
            return e if (left is e.left and right is e.right) else ast.Binary(e.loc, e.op, left, right)
        if isinstance(e, ast.Quant):
            return ast.Quant(e.loc, e.vars, self._expand_x(e.body, stack))
        if isinstance(e, ast.Stamp):
            return ast.Stamp(e.loc, self._expand_x(e.time, stack), self._expand_x(e.body, stack))
        if isinstance(e, ast.Range):
            return ast.Range(e.loc, self._expand_x(e.lo, stack), self._expand_x(e.hi, stack))
        return e


class _TooDeep(Exception):
    """Measuring a macro expansion went past MAX_NESTING levels."""


def _substitute(e: ast.Expr, args: tuple) -> ast.Expr:
    if isinstance(e, ast.Param):
        if e.index > len(args):
            raise ResolveError(f"macro parameter #{e.index} has no argument", e.loc)
        return args[e.index - 1]
    if isinstance(e, ast.Name):
        return ast.Name(e.loc, e.name, tuple(_substitute(a, args) for a in e.args)) if e.args else e
    if isinstance(e, ast.Unary):
        return ast.Unary(e.loc, e.op, _substitute(e.arg, args))
    if isinstance(e, ast.Binary):
        return ast.Binary(e.loc, e.op, _substitute(e.left, args), _substitute(e.right, args))
    if isinstance(e, ast.Quant):
        return ast.Quant(e.loc, e.vars, _substitute(e.body, args))
    if isinstance(e, ast.Stamp):
        return ast.Stamp(e.loc, _substitute(e.time, args), _substitute(e.body, args))
    if isinstance(e, ast.Range):
        return ast.Range(e.loc, _substitute(e.lo, args), _substitute(e.hi, args))
    return e
