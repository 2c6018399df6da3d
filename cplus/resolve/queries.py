"""``:- query`` and ``:- nmquery``: a label, a range of plan lengths and the conditions on the plan.

Queries are the only place for time stamps and ``maxstep``, and of two queries with one label
the first is answered (the later is warned and ignored, as CCALC answers the first), so they
are resolved apart from laws.  A query that cannot be resolved is kept with its error, raised
when it is asked: as in CCALC, a bad query fails alone and the file's others are answered.
An nmquery's items are causal rules (completed on their own when it is answered, see
:class:`cplus.sat.horizon.QuerySession`); its labels are a namespace of their own, as in CCALC.
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import CPlusError, DefinitenessError, Location, QueryError
from cplus.program import QuerySpec
from cplus.resolve.core import _Scope
from cplus.resolve.formulas import _Formulas
from cplus.signature import StepSort

NM_MACROS = ("anyFluentValues", "anyActions", "anyHistory", "anyInitialState", "cwaActions")
"""CCALC's macros for nmquery rules (macros.std); a macro or constant of the name wins."""


class _Queries(_Formulas):
    def _st_Query(self, stmt: ast.Query) -> None:
        try:
            spec = self._query_spec(stmt)
        except CPlusError as exc:
            # CCALC fails such a query when it is asked and answers the file's others: the
            # query keeps its label (of two with one label the first still wins) and its error
            label = self._label_of(stmt)
            if label is None:
                raise
            spec = QuerySpec(label, 0, 0, (), stmt.loc, () if stmt.nm else None, error=exc)
        what = "nmquery" if stmt.nm else "query"
        known = self.program.nmqueries if stmt.nm else self.program.queries
        if any(q.label == spec.label for q in known):
            # CCALC asserts every query_problem and answers the first of a label
            # (ccalc.pl, process_query: assertz; query/2: query_problem(Label, ...) -> true)
            self.diag.warn(f"{what} label '{spec.label}' is used again; as in CCALC the first {what} with this "
                           "label is the one answered, this one is ignored", stmt.loc)
            return
        known.append(spec)

    def _label_of(self, stmt: ast.Query) -> str | None:
        """The label of a query whose items could not be resolved (its first ``label ::``, 0
        without one), or None when the label itself is what is wrong."""
        for it in stmt.items:
            if isinstance(it, ast.QueryLabel):
                try:
                    return self._label(it.label)
                except CPlusError:
                    return None
        return "0"

    def _query_spec(self, stmt: ast.Query) -> QuerySpec:
        label = "0"
        lo: int = 0
        hi: int | None = 0     # CCALC: a query without `maxstep` is answered at maxstep 0
        seen_label = seen_max = False
        any_length: Location | None = None          # `maxstep :: any`
        invariant: tuple[ir.Formula, Location] | None = None
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
                if it.hi is it.lo and self._query_word(it.lo, "any"):
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
            elif isinstance(it, ast.QueryRule):
                rules.extend(self._nm_rule(it))
            elif isinstance(it.formula, ast.Stamp) and self._query_word(it.formula.time, "invariant"):
                if invariant is not None:
                    raise QueryError("a query has at most one invariant", it.loc)
                invariant = (self._formula(it.formula.body, _Scope(query=True)), it.formula.body.loc)
            else:
                items.append((self._formula(it.formula, _Scope(query=True)), it.loc))
        if any_length is not None or invariant is not None:
            from cplus.invariant import check_query_shape
            check_query_shape(items, invariant, any_length, stmt.loc)
            hi = None           # never searched horizon by horizon (QuerySpec.invariant)
        return QuerySpec(label, lo, hi, tuple(items), stmt.loc, tuple(rules) if stmt.nm else None,
                         invariant=invariant)

    def _query_word(self, e: ast.Expr, word: str) -> bool:
        """Whether ``e`` is the bare word of a query field (``any``, ``invariant``) that no
        macro redefines: CCALC's query words are not reserved elsewhere."""
        return isinstance(e, ast.Name) and e.name == word and not e.args and (word, 0) not in self.macros

    def _nm_rule(self, rule: ast.QueryRule) -> list[tuple[ir.Formula | None, ir.Formula, Location]]:
        """One ``caused H if B`` of an nmquery as rules ``(literal, body, loc)``, one per conjunct
        of the head (None: ``false``); ``default H if B`` is ``caused H if H & B``."""
        scope = _Scope(query=True)
        if isinstance(rule.head, ast.Name) and not rule.head.args and rule.head.name in NM_MACROS \
                and rule.body is None and not rule.default and (rule.head.name, 0) not in self.macros \
                and not self.sig.constants_named(rule.head.name):
            return self._nm_macro(rule.head.name, rule.loc)
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

    def _nm_macro(self, name: str, loc: Location) -> list[tuple[ir.Formula | None, ir.Formula, Location]]:
        """CCALC's nmquery macros (macros.std, "Macros used in queries"): ``t: A <= t: A`` for every
        atom A of the kinds each names, at every step it exists: ``anyFluentValues`` (simple and
        statically determined fluents, rigid constants), ``anyActions`` (actions and attributes,
        abnormalities aside), ``anyHistory`` (both), ``anyInitialState`` (simple fluents at 0),
        ``cwaActions`` (``t: -a <= t: -a`` for Boolean actions; attributes free)."""
        kinds = {"anyFluentValues": ("simple", "sd", "rigid"), "anyActions": ("action", "attribute"),
                 "anyHistory": ("simple", "sd", "rigid", "action", "attribute"), "anyInitialState": ("initial",),
                 "cwaActions": ("cwa", "attribute")}[name]
        out: list[tuple[ir.Formula | None, ir.Formula, Location]] = []
        for d in list(self.sig.constants.values()):
            if d.hidden:
                continue
            k = d.kind
            group = ("simple" if k in ("simpleFluent", "inertialFluent") else "sd" if k == "sdFluent"
                     else "rigid" if k == "rigid" else "attribute" if k == "attribute"
                     else "action" if k in ("exogenousAction", "action") else None)
            if group is None or not ({group, "initial" if group == "simple" else "",
                                      "cwa" if group == "action" else ""} & set(kinds)):
                continue
            args = tuple(ir.Var(f"_nm{i}", s, loc) for i, s in enumerate(d.argsorts))
            cst = ir.Cst(d, args, loc)
            if "cwa" in kinds and group == "action":
                if not _boolean_atom(ir.Atom(cst, ir.Lit("true"), loc)):
                    continue
                lits: list[ir.Formula] = [ir.Not(ir.Atom(cst, ir.Lit("true"), loc))]
            else:
                lits = [ir.Atom(cst, ir.Var("_nmv", d.domain, loc), loc)]
                if group == "attribute":
                    lits.append(ir.Atom(cst, ir.Lit("none"), loc))
            if group == "rigid":
                out.extend((lit, lit, loc) for lit in lits)
                continue
            step: ir.Term = ir.Lit(0) if "initial" in kinds else ir.Var("_nmt", StepSort(group in ("action", "attribute")), loc)
            out.extend((ir.StampF(step, lit, loc), ir.StampF(step, lit, loc), loc) for lit in lits)
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
