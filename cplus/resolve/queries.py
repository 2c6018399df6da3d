"""``:- query``: a label, a range of plan lengths and the conditions on the plan.

Queries are the only place for time stamps and ``maxstep``, and a query replaces an earlier
one of the same label (warned) rather than adding to it, so they are resolved apart from laws.
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import Location, QueryError
from cplus.program import QuerySpec
from cplus.resolve.core import _Scope
from cplus.resolve.formulas import _Formulas


class _Queries(_Formulas):
    def _st_Query(self, stmt: ast.Query) -> None:
        label = "0"
        lo, hi = 0, None
        seen_label = seen_max = False
        any_length: Location | None = None          # `maxstep :: any`
        invariant: tuple[ir.Formula, Location] | None = None
        items: list[tuple[ir.Formula, Location]] = []
        for it in stmt.items:
            if isinstance(it, ast.QueryLabel):
                if seen_label:
                    raise QueryError("a query has at most one label", it.loc)
                seen_label, label = True, self._label(it.label)
            elif isinstance(it, ast.QueryMaxstep):
                if seen_max:
                    raise QueryError("a query has at most one maxstep", it.loc)
                seen_max = True
                if it.hi is it.lo and self._keyword(it.lo, "any"):
                    any_length = it.loc
                    continue
                lo_e = self._expand(it.lo)
                hi_e = it.hi
                if isinstance(lo_e, ast.Range) and it.hi is it.lo:   # `maxstep :: r`, r a macro for lo..hi
                    hi_e = lo_e.hi
                    lo_e = lo_e.lo
                lo = self._static_int(lo_e)
                hi = None if hi_e is None else self._static_int(hi_e)
                if lo < 0 or (hi is not None and hi < lo):
                    bounds = f"{lo}..{'infinity' if hi is None else hi}"
                    raise QueryError(f"malformed maxstep {bounds}: need 0 =< min =< max", it.loc)
            elif isinstance(it.formula, ast.Stamp) and self._keyword(it.formula.time, "invariant"):
                if invariant is not None:
                    raise QueryError("a query has at most one invariant", it.loc)
                invariant = (self._formula(it.formula.body, _Scope(query=True)), it.formula.body.loc)
            else:
                items.append((self._formula(it.formula, _Scope(query=True)), it.loc))
        if any_length is not None or invariant is not None:
            from cplus.invariant import check_query_shape
            check_query_shape(items, invariant, any_length, stmt.loc)
        if self.program.query(label) is not None:
            self.diag.warn(f"query label '{label}' is used again; the later query replaces the earlier",
                           stmt.loc)
            self.program.queries = [q for q in self.program.queries if q.label != label]
        self.program.queries.append(QuerySpec(label, lo, hi, tuple(items), stmt.loc, invariant))

    def _keyword(self, e: ast.Expr, word: str) -> bool:
        """Whether ``e`` is the bare word of a query field (``any``, ``invariant``) that no
        macro redefines: CCALC's query words are not reserved elsewhere."""
        return isinstance(e, ast.Name) and e.name == word and not e.args and (word, 0) not in self.macros

    def _label(self, e: ast.Expr) -> str:
        """A query label: a name, or an integer (also given by a macro or an expression)."""
        expanded = self._expand(e)
        if isinstance(expanded, ast.Name) and not expanded.args and not expanded.name[0].isupper():
            return expanded.name
        return str(self._static_int(expanded))
