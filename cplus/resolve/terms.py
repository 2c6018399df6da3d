"""Terms, and the sort expressions and integers written in declarations.

They are one mixin because they call each other: a sort may be a range whose bounds are
integer expressions (``cell(1..n-1)``), an integer expression is evaluated as a term, and a
term may name a sort (``var(s, k)``).  Formulas, and every statement resolver, build on it.
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import Location, ResolveError, SortError
from cplus.limits import MAX_INT, MAX_RANGE, count
from cplus.resolve.core import _KIND_ALIASES, _ast_text, _is_boolean, _no_sort_here, _Scope, _show
from cplus.resolve.macros import _Macros
from cplus.signature import USER_KINDS, KindSort, NamedSort, RangeSort, SortExpr, StepSort

_ARITH_FUNS = {("abs", 1): "abs", ("min", 2): "min", ("max", 2): "max"}


class _Terms(_Macros):
    # ------------------------------------------------------------------ sort expressions
    def _sort_info(self, name: str, loc: Location):
        info = self.sig.sorts.get(name)
        if info is None:
            raise SortError(f"unknown sort '{name}'", loc)
        return info

    def _sort_expr(self, spec: ast.SortSpec, for_variable: bool = False) -> SortExpr:
        if not isinstance(spec, (ast.SortRef, ast.Range)):
            # a macro call (or any expression) where a sort is expected: expand, then classify
            e = self._expand(spec)
            if isinstance(e, ast.Name) and not e.args:
                e = ast.SortRef(e.loc, e.name)
            elif isinstance(e, ast.Binary) and e.op == "+" and isinstance(e.left, ast.Name) and not e.left.args \
                    and isinstance(e.right, ast.Name) and e.right.name == "none":
                e = ast.SortRef(e.loc, e.left.name, True)
            if not isinstance(e, (ast.SortRef, ast.Range)):
                if isinstance(spec, ast.Name) and spec.args and (spec.name, len(spec.args)) not in self.macros:
                    raise SortError(f"unknown constant kind or macro '{spec.name}/{len(spec.args)}' (the kinds: "
                                    f"{', '.join(sorted(USER_KINDS))})", spec.loc)
                raise SortError("expected a sort: a sort name, 's*', 's+none' or a range 'lo..hi'", spec.loc)
            spec = e
        if isinstance(spec, ast.Range):
            lo_e, hi_e = self._expand(spec.lo), self._expand(spec.hi)
            lo, hi = self._static_int(lo_e), self._static_int(hi_e)
            if hi < lo:
                raise SortError(f"empty range {lo}..{hi}: a sort must have at least one object", spec.loc)
            if hi - lo + 1 > MAX_RANGE:
                raise SortError(f"the range {lo}..{hi} has {count(hi - lo + 1)} integers; a range used as a "
                                f"sort may have at most {count(MAX_RANGE)}", spec.loc)
            return RangeSort(lo, hi)
        name = spec.name
        if (name, 0) in self.macros:
            body = self._expand(ast.Name(spec.loc, name))
            if isinstance(body, ast.Range):
                return self._sort_expr(body, for_variable)
            if isinstance(body, ast.Name) and not body.args and body.name != name:
                return self._sort_expr(ast.SortRef(spec.loc, body.name, spec.star), for_variable)
        if name == "afValue":
            if self.sig.max_additive is None:
                raise SortError("'afValue' needs ':- maxAdditive :: N.' before it", spec.loc)
            m = self.sig.max_additive
            return RangeSort(0, m, spec.star)
        if for_variable and name in ("step", "astep") and not spec.star:
            return StepSort(name == "astep")
        if for_variable and name in _KIND_ALIASES and not spec.star:
            return KindSort(name)
        self._sort_info(name, spec.loc)
        return NamedSort(name, spec.star)

    def _static_int(self, e: ast.Expr) -> int:
        """Evaluate a constant-free integer expression written in a declaration."""
        t = self._term(self._expand(e), _Scope())
        if isinstance(t, ir.Lit) and isinstance(t.value, int):
            return t.value
        raise SortError("expected an integer expression (numbers, macros and arithmetic only)",
                        getattr(e, "loc", None))

    # ------------------------------------------------------------------ terms
    def _var(self, name: str, loc: Location, scope: _Scope) -> ir.Var | None:
        v = scope.local.get(name) or self.variables.get(name)
        if v is not None:
            return ir.Var(v.name, v.sort, loc)
        if name.startswith("V_") and name[2:] in self.sig.sorts:
            return ir.Var(name, NamedSort(name[2:]), loc)
        return None

    def _term(self, e: ast.Expr, scope: _Scope) -> ir.Term:
        e = self._expand(e)
        return self._term_x(e, scope)

    def _term_x(self, e: ast.Expr, scope: _Scope) -> ir.Term:
        if isinstance(e, ast.Num):
            return ir.Lit(e.value)
        if isinstance(e, ast.Name):
            return self._name_term(e, scope)
        if isinstance(e, ast.Unary):
            if e.op == "not":
                return self._term_x(_rotate_minus(e.arg, e.loc), scope) if isinstance(e.arg, ast.Binary) \
                    else self._arith("neg", (self._term_x(e.arg, scope),), e.loc)
            if e.op == "cneg":
                return self._ccalc_minus(e, scope)
            return self._arith("neg" if e.op == "-" else "abs", (self._term_x(e.arg, scope),), e.loc)
        if isinstance(e, ast.Binary):
            if e.op in ast.ARITH_OPS:
                return self._arith(e.op, (self._term_x(e.left, scope), self._term_x(e.right, scope)), e.loc)
            raise ResolveError(f"expected a term, found a formula ('{e.op}')", e.loc)
        if isinstance(e, ast.MaxStep):
            if not scope.query:
                raise ResolveError("'maxstep' may only occur in queries", e.loc)
            return ir.MaxStepT(e.loc)
        if isinstance(e, ast.Stamp):
            if not scope.query:
                raise ResolveError("time stamps 'i: ...' may only occur in queries", e.loc)
            return ir.StampT(self._term_x(e.time, scope), self._term_x(e.body, scope), e.loc)
        if isinstance(e, ast.Param):
            raise ResolveError(f"macro parameter #{e.index} outside a macro body", e.loc)
        if isinstance(e, ast.Quant):
            raise ResolveError("expected a term, found a quantified formula", e.loc)
        _no_sort_here(e)
        raise ResolveError("expected a term", e.loc)

    def _ccalc_minus(self, e: ast.Unary, scope: _Scope) -> ir.Term:
        """``-c=v`` without parentheses: CCALC (Prolog) reads ``(-c)=v``, minus binding tighter
        than any comparison.  Taken so, with a warning that names the form for "c is not v";
        refused, as CCALC refuses it ("Invalid expression"), when ``c`` has no integer values."""
        arg = self._term_x(e.arg, scope)
        text = _ast_text(e.arg)
        integer = True
        if isinstance(arg, ir.Cst):
            integer = self._may_be_int(arg.decl.domain) and not _is_boolean(arg.decl.domain)
        elif isinstance(arg, ir.Lit):
            integer = isinstance(arg.value, int)
        elif isinstance(arg, ir.Var):
            integer = self._may_be_int(arg.sort)
        if not integer:
            raise SortError(f"'-{text}' before a comparison is arithmetic minus in CCALC ('(-{text})=...'), and "
                            f"'{text}' has no integer values (CCALC: Invalid expression); write '-({text}=...)' "
                            "for the negation", e.loc)
        self.diag.warn(f"'-{text}' before a comparison means '(-{text})' in CCALC (minus binds tighter than "
                       f"'='): '-{text}=v' says {text} = -v; write '-({text}=v)' for '{text} is not v'", e.loc)
        return self._arith("neg", (arg,), e.loc)

    def _arith(self, op: str, args: tuple, loc: Location) -> ir.Term:
        for a in args:
            if isinstance(a, ir.Lit) and not isinstance(a.value, int):
                raise SortError(f"arithmetic on the object '{_show(a.value)}' (not an integer)", loc)
            if isinstance(a, ir.Var) and not self._may_be_int(a.sort):
                raise SortError(f"arithmetic on variable {a.name} of sort '{a.sort}', which has no integers",
                                a.loc)
        if all(isinstance(a, ir.Lit) for a in args):
            from cplus.ground.arith import apply_arith  # local: ground depends on ir, not vice versa
            try:
                value = apply_arith(op, [a.value for a in args])
            except ZeroDivisionError:
                raise SortError("division by zero", loc) from None
            if not -MAX_INT - 1 <= value <= MAX_INT:
                raise SortError(f"the value of this expression, {count(value)}, is outside the integers "
                                f"(-2^63..2^63-1)", loc)
            return ir.Lit(value)
        return ir.Arith(op, args, loc)

    def _may_be_int(self, sort: SortExpr) -> bool:
        if isinstance(sort, (RangeSort, StepSort)):
            return True
        if isinstance(sort, KindSort):
            return False
        return any(isinstance(o, int) for o in self.sig.objects_of(sort)) or not self.sig.objects_of(sort)

    def _name_term(self, e: ast.Name, scope: _Scope) -> ir.Term:
        name, n = e.name, len(e.args)
        if name[0].isupper():
            if n:
                raise ResolveError(f"'{name}' looks like a variable but has arguments", e.loc)
            v = self._var(name, e.loc, scope)
            if v is None:
                raise ResolveError(f"unknown variable '{name}' (declare it in ':- variables')", e.loc)
            return v
        decl = self.sig.lookup(name, n)
        if decl is not None:
            args = tuple(self._term_x(a, scope) for a in e.args)
            return ir.Cst(decl, args, e.loc)
        if n == 0:
            if name in self.objects:
                return ir.Lit(name)
            if name in self.sig.sorts:
                raise ResolveError(f"'{name}' is a sort, not an object or constant", e.loc)
            if self.sig.constants_named(name):
                arities = ", ".join(str(d.arity) for d in self.sig.constants_named(name))
                raise ResolveError(f"constant '{name}' takes {arities} argument(s), not 0", e.loc)
            raise ResolveError(f"unknown name '{name}'", e.loc)
        if (name, n) in _ARITH_FUNS:
            return self._arith(_ARITH_FUNS[(name, n)], tuple(self._term_x(a, scope) for a in e.args), e.loc)
        if (name, n) in self.sig.constructors:
            args = tuple(self._term_x(a, scope) for a in e.args)
            if all(isinstance(a, ir.Lit) for a in args):
                value = (name,) + tuple(a.value for a in args)  # type: ignore[misc, union-attr]
                if value not in self.sig.object_order:
                    raise SortError(f"'{_show(value)}' is not a declared object", e.loc)
                return ir.Lit(value)
            return ir.Obj(name, args, e.loc)
        if name == "var" and n == 2:
            sort_e = e.args[0]
            if not isinstance(sort_e, ast.Name) or sort_e.args:
                raise ResolveError("var(s, k) needs a sort name s", e.loc)
            sort = self._sort_expr(ast.SortRef(sort_e.loc, sort_e.name), for_variable=True)
            return ir.Var(f"var({sort_e.name},{_ast_text(e.args[1])})", sort, e.loc)
        ext = self.externals.get(name, n)
        if ext is not None:
            args = tuple(self._term_x(a, scope) for a in e.args)
            if ext.predicate is True:
                raise ResolveError(f"'{name}/{n}' is an external predicate, not a function", e.loc)
            return ir.Ext(name, ext.fn, args, e.loc)
        known = self.sig.constants_named(name)
        if known:
            arities = ", ".join(str(d.arity) for d in known)
            raise ResolveError(f"constant '{name}' takes {arities} argument(s), not {n}", e.loc)
        raise ResolveError(f"unknown constant or function '{name}/{n}'", e.loc)


def _rotate_minus(e: ast.Binary, loc: Location) -> ast.Expr:
    """``-(a op b)`` read as a term: the minus belongs to the leftmost operand."""
    if e.op in ast.ARITH_OPS:
        left = _rotate_minus(e.left, loc) if isinstance(e.left, ast.Binary) else ast.Unary(loc, "-", e.left)
        return ast.Binary(e.loc, e.op, left, e.right)
    raise ResolveError(f"expected a term, found a formula ('{e.op}')", e.loc)
