"""Formulas: what laws and queries are made of.

Apart from terms because only laws and queries need them; declarations and show patterns
stop at terms.  A formula is where an atom ``c = v`` is told from a comparison of terms, so
the warning for a value outside a constant's range is given here.
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import Location, ResolveError, SortError
from cplus.resolve.core import _ast_text, _is_boolean, _no_sort_here, _Scope
from cplus.resolve.terms import _Terms
from cplus.signature import KindSort, NamedSort, RangeSort, StepSort


class _Formulas(_Terms):
    def _formula(self, e: ast.Expr, scope: _Scope) -> ir.Formula:
        return self._formula_x(self._expand(e), scope)

    def _formula_x(self, e: ast.Expr, scope: _Scope) -> ir.Formula:
        if isinstance(e, ast.Binary):
            op = e.op
            if op in ("&", ",", "&&"):
                return ir.conj((self._formula_x(e.left, scope), self._formula_x(e.right, scope)))
            if op in ("++", "||"):
                left, right = self._formula_x(e.left, scope), self._formula_x(e.right, scope)
                items = (left.items if isinstance(left, ir.Or) else (left,)) + \
                        (right.items if isinstance(right, ir.Or) else (right,))
                return ir.Or(items)
            if op == "->>":
                return ir.Imp(self._formula_x(e.left, scope), self._formula_x(e.right, scope))
            if op == "<->>":
                return ir.Iff(self._formula_x(e.left, scope), self._formula_x(e.right, scope))
            if op in ast.COMPARE_OPS:
                return self._comparison(e, scope)
            raise ResolveError(f"expected a formula, found an arithmetic term ('{op}')", e.loc)
        if isinstance(e, ast.Unary):
            if e.op == "not":
                return ir.Not(self._formula_x(e.arg, scope))
            raise ResolveError("expected a formula, found an arithmetic term", e.loc)
        if isinstance(e, ast.Name):
            return self._name_formula(e, scope)
        if isinstance(e, ast.Quant):
            return self._quant(e, scope)
        if isinstance(e, ast.Stamp):
            if not scope.query:
                raise ResolveError("time stamps 'i: ...' may only occur in queries", e.loc)
            return ir.StampF(self._term_x(e.time, scope), self._formula_x(e.body, scope), e.loc)
        if isinstance(e, ast.Num):
            raise ResolveError(f"expected a formula, found the number {e.value}", e.loc)
        if isinstance(e, ast.MaxStep):
            raise ResolveError("expected a formula, found 'maxstep'", e.loc)
        if isinstance(e, ast.Param):
            raise ResolveError(f"macro parameter #{e.index} outside a macro body", e.loc)
        _no_sort_here(e)
        raise ResolveError("expected a formula", e.loc)

    def _comparison(self, e: ast.Binary, scope: _Scope) -> ir.Formula:
        left, right = self._term_x(e.left, scope), self._term_x(e.right, scope)
        if isinstance(left, ir.Cst) and e.op in ("=", "\\="):
            atom = ir.Atom(left, right, e.loc)
            self._check_value(left, right, e.loc)
            return atom if e.op == "=" else ir.Not(atom)
        if isinstance(left, ir.Var) and isinstance(left.sort, KindSort) and e.op in ("=", "\\=") \
                and not isinstance(right, ir.Cst):
            atom = ir.Atom(left, right, e.loc)
            return atom if e.op == "=" else ir.Not(atom)
        if e.op == "\\=":
            return ir.Not(ir.Cmp("=", left, right, e.loc))
        return ir.Cmp(e.op, left, right, e.loc)

    def _check_value(self, cst: ir.Cst, value: ir.Term, loc: Location) -> None:
        if isinstance(value, ir.Lit) and isinstance(value.value, int) and isinstance(cst.decl.domain, RangeSort):
            d = cst.decl.domain
            if not (d.lo <= value.value <= d.hi):
                self.diag.warn(f"{value.value} is outside the domain {d} of '{cst.decl.name}'; "
                               "this atom is always false", loc)

    def _name_formula(self, e: ast.Name, scope: _Scope) -> ir.Formula:
        name, n = e.name, len(e.args)
        if n == 0 and name in ("true", "false"):
            return ir.TRUE if name == "true" else ir.FALSE
        if not name[0].isupper():
            decl = self.sig.lookup(name, n)
            if decl is None:
                ext = self.externals.get(name, n)
                if ext is not None and ext.predicate is not False:
                    return ir.ExtPred(name, ext.fn, tuple(self._term_x(a, scope) for a in e.args), e.loc)
        t = self._name_term(e, scope)
        if isinstance(t, ir.Cst):
            if not _is_boolean(t.decl.domain):
                raise SortError(f"'{t.decl.name}' is not Boolean (its domain is {t.decl.domain}); "
                                f"write {t.decl.name}(...)=value", e.loc)
            return ir.Atom(t, ir.Lit("true"), e.loc)
        if isinstance(t, ir.Var):
            if isinstance(t.sort, KindSort):
                return ir.Atom(t, ir.Lit("true"), e.loc)
            if isinstance(t.sort, NamedSort) and t.sort.name == "boolean":
                return ir.Cmp("=", t, ir.Lit("true"), e.loc)
            raise SortError(f"variable {t.name} of sort '{t.sort}' is not a formula", e.loc)
        raise ResolveError(f"expected a formula, found the object '{_ast_text(e)}'", e.loc)

    def _quant(self, e: ast.Quant, scope: _Scope) -> ir.Formula:
        inner = scope
        qvars: list[tuple[bool, ir.Var]] = []
        for qv in e.vars:
            base: ir.Var | None
            if qv.name.startswith("var("):     # CCALC's anonymous variable var(s, k)
                sort = self._sort_expr(ast.SortRef(qv.loc, qv.name[4:].split(",")[0]), for_variable=True)
                base = ir.Var(qv.name, sort, qv.loc)
            else:
                base = self._var(qv.name, qv.loc, _Scope()) if qv.name[0].isupper() else None
            if base is None:
                raise ResolveError(f"unknown variable '{qv.name}' in a quantifier", qv.loc)
            var = ir.Var(qv.name, base.sort, qv.loc)
            if isinstance(var.sort, StepSort) and not scope.query:
                raise ResolveError("variables over steps may only occur in queries", qv.loc)
            inner = inner.with_var(var)
            qvars.append((qv.exists, var))
        body = self._formula_x(e.body, inner)
        for exists, var in reversed(qvars):
            body = ir.Quant(exists, var, body)
        return body
