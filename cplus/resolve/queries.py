"""``:- query`` and ``:- nmquery``: a label, a range of plan lengths and the conditions on the plan.

Queries are the only place for time stamps and ``maxstep``, and a query replaces an earlier
one of the same label (warned) rather than adding to it, so they are resolved apart from laws.
An nmquery's items are causal rules (completed on their own when it is answered, see
:class:`cplus.sat.horizon.QuerySession`); its labels are a namespace of their own, as in CCALC.
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import DefinitenessError, Location, QueryError
from cplus.program import QuerySpec
from cplus.resolve.core import _Scope
from cplus.resolve.formulas import _Formulas


class _Queries(_Formulas):
    def _st_Query(self, stmt: ast.Query) -> None:
        label = "0"
        lo: int = 0
        hi: int | None = 0     # CCALC: a query without `maxstep` is answered at maxstep 0
        seen_label = seen_max = False
        items: list[tuple[ir.Formula, Location]] = []
        rules: list[tuple[ir.Formula | None, ir.Formula, Location]] = []
        for it in stmt.items:
            if isinstance(it, ast.QueryLabel):
                if seen_label:
                    raise QueryError("a query has at most one label", it.loc)
                seen_label, label = True, self._label(it.label)
            elif isinstance(it, ast.QueryMaxstep):
                if seen_max:
                    raise QueryError("a query has at most one maxstep", it.loc)
                seen_max = True
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
            elif isinstance(it, ast.QueryRule):
                rules.extend(self._nm_rule(it))
            else:
                items.append((self._formula(it.formula, _Scope(query=True)), it.loc))
        what = "nmquery" if stmt.nm else "query"
        known = self.program.nmqueries if stmt.nm else self.program.queries
        if any(q.label == label for q in known):
            self.diag.warn(f"{what} label '{label}' is used again; the later {what} replaces the earlier",
                           stmt.loc)
            known[:] = [q for q in known if q.label != label]
        known.append(QuerySpec(label, lo, hi, tuple(items), stmt.loc, tuple(rules) if stmt.nm else None))

    def _nm_rule(self, rule: ast.QueryRule) -> list[tuple[ir.Formula | None, ir.Formula, Location]]:
        """One ``caused H if B`` of an nmquery as rules ``(literal, body, loc)``, one per conjunct
        of the head (None: ``false``); ``default H if B`` is ``caused H if H & B``."""
        scope = _Scope(query=True)
        head = self._formula(rule.head, scope)
        body = ir.TRUE if rule.body is None else self._formula(rule.body, scope)
        if rule.default:
            body = ir.conj((head, body))
        out: list[tuple[ir.Formula | None, ir.Formula, Location]] = []
        for lit in ir.conjuncts(head):
            if lit == ir.FALSE:
                out.append((None, body, rule.loc))
                continue
            inner = lit.body if isinstance(lit, ir.StampF) else lit
            positive = inner.arg if isinstance(inner, ir.Not) else inner
            if not isinstance(positive, ir.Atom) or (isinstance(inner, ir.Not) and not _boolean_atom(positive)):
                raise DefinitenessError("the head of an nmquery rule is a literal ('t: c=v', 't: p', 't: -p'), a "
                                        "conjunction of them, or false: anything else makes the rules "
                                        "non-definite", rule.loc)
            out.append((lit, body, rule.loc))
        return out

    def _label(self, e: ast.Expr) -> str:
        """A query label: a name, or an integer (also given by a macro or an expression)."""
        expanded = self._expand(e)
        if isinstance(expanded, ast.Name) and not expanded.args and not expanded.name[0].isupper():
            return expanded.name
        return str(self._static_int(expanded))


def _boolean_atom(a: ir.Atom) -> bool:
    cst = a.cst
    sort = cst.decl.domain if isinstance(cst, ir.Cst) else None
    return sort is None or (getattr(sort, "name", None) == "boolean" and not getattr(sort, "star", False))
