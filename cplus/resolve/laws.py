"""Laws: each causal law classified and expanded into basic laws.

The largest resolver, and one concern: a law's kind (``causes``, ``default``, ``inertial``,
``increments``, ...) decides how it becomes ``caused H if B after A`` and which class
(static, dynamic, action, rigid) it falls in, and the head checks here are what keep the
causal theory definite.  ``unless`` and ``noconcurrency`` are forms of laws, so they are
resolved here too.
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import DefinitenessError, ResolveError, SortError
from cplus.program import BasicLaw, IncrementLaw, StampedRule
from cplus.resolve.core import _is_boolean, _Scope
from cplus.resolve.formulas import _Formulas
from cplus.signature import ACTION_KINDS, FLUENT_KINDS, ConstDecl, NamedSort, RangeSort, SortExpr, StepSort


class _Laws(_Formulas):
    def _st_NoConcurrency(self, stmt: ast.NoConcurrency) -> None:
        self.program.noconcurrency.append((stmt.strong, stmt.loc))

    def _st_Law(self, law: ast.Law) -> None:
        scope = _Scope(law=law.kind)
        if law.kind == "fact" and (_has_stamp(law.head) or (law.if_ is not None and _has_stamp(law.if_))):
            self._stamped_fact(law)
            return
        if law.kind in ("exogenous", "inertial", "rigid"):
            self._frame_law(law, scope)
            return
        f = lambda x: None if x is None else self._formula(x, scope)  # noqa: E731
        action = f(law.action) if law.kind != "increments" else None   # first in the text
        head = f(law.head) if law.kind != "increments" else None
        if_ = f(law.if_) or ir.TRUE
        after = f(law.after)
        where = f(law.where)
        if where is not None and ir.constants_in(where):
            raise ResolveError("a 'where' condition may not mention constants", law.loc)
        kind = law.kind
        if after is not None and kind in ("causes", "may_cause", "nonexecutable"):
            raise ResolveError(f"'{kind.replace('_', ' ')}' takes no 'after' part", law.loc)
        if kind == "increments":
            self._increment_law(law, scope, if_, where)
            return
        if kind in ("caused", "fact"):
            self._add(law, head, if_, after, where, "caused")
        elif kind == "default":
            self._add(law, head, ir.conj((head, if_)), after, where, "default")
        elif kind == "causes":
            assert action is not None
            if self._mentions_actions(head):   # 'a causes b', b an action: caused b if a
                self._add(law, head, ir.conj((action, if_)), None, where, "causes")
            else:
                self._add(law, head, ir.TRUE, ir.conj((action, if_)), where, "causes")
        elif kind == "may_cause":
            assert action is not None
            self._add(law, head, head, ir.conj((action, if_)), where, "may cause")  # type: ignore[arg-type]
        elif kind == "nonexecutable":
            self._add(law, None, ir.TRUE, ir.conj((head, if_)), where, "nonexecutable")
        elif kind == "constraint":
            body = ir.conj((ir.Not(head), if_))  # type: ignore[arg-type]
            if after is None and self._mentions_actions(head):
                raise ResolveError("'constraint' cannot mention actions; use 'always' or 'nonexecutable'",
                                   law.loc)
            self._add(law, None, body, after, where, "constraint")
        elif kind == "always":
            if law.if_ is not None:
                raise ResolveError("'always F' takes no 'if' part", law.loc)
            self._add(law, None, ir.TRUE, ir.conj((ir.Not(head), after or ir.TRUE)), where, "always")  # type: ignore[arg-type]
        elif kind == "never":
            self._add(law, None, ir.conj((head, if_)), after, where, "never")
        else:  # pragma: no cover - grammar covers the kinds
            raise ResolveError(f"unsupported law '{kind}'", law.loc)

    def _stamped_fact(self, law: ast.Law) -> None:
        """``0: q.``, ``1: p if 0: q.``: a causal rule of the steps it names, as CCALC reads a
        fact outside a query (ccalc.pl, ``read_fail_loop``: a term that is no law becomes
        ``insert_rule_schema((Term <= true), ...)``): its head literals are caused at their
        stamps when its body holds.  Free variables are universal over the head's and
        existential over the body's alone (one rule per instance).  A head conjunct without
        constants (``L \\= L1``) that is false makes that instance a rule with head false.
        See :class:`cplus.program.StampedRule` for how it reaches the completion."""
        if law.after is not None or law.unless is not None:
            raise ResolveError("a time-stamped fact takes no 'after' or 'unless' part (its stamps name "
                               "its steps)", law.loc)
        if not _has_stamp(law.head):
            raise ResolveError("a fact with time stamps in its 'if' part needs them in its head too "
                               "(write 't: F if G.')", law.loc)
        scope = _Scope(query=True)
        head = self._formula(law.head, scope)  # type: ignore[arg-type]
        body = self._formula(law.if_, scope) if law.if_ is not None else ir.TRUE
        if law.where is not None:
            where = self._formula(law.where, scope)
            if ir.constants_in(where):
                raise ResolveError("a 'where' condition may not mention constants", law.loc)
            body = ir.conj((where, body))
        for step, lit in _stamped_literals(head, None, law):
            if step is None:                       # a condition: false in an instance -> head false
                if lit != ir.TRUE:
                    self.program.facts.append(StampedRule(None, 0, _exists(ir.conj((body, ir.Not(lit))), ()),
                                                          law.loc))
                continue
            if lit == ir.FALSE:
                self.program.facts.append(StampedRule(None, step, _exists(body, ()), law.loc))
                continue
            self._stamped_rule(law, step, lit, body)

    def _stamped_rule(self, law: ast.Law, step: int, lit: ir.Formula, body: ir.Formula) -> None:
        atom = lit.arg if isinstance(lit, ir.Not) else lit
        assert isinstance(atom, ir.Atom)
        if isinstance(atom.cst, ir.Var):
            raise ResolveError("the head of a time-stamped fact names its constant (not a variable over "
                               "a kind of constants)", law.loc)
        kind = atom.cst.decl.kind
        if kind == "rigid":
            raise ResolveError(f"'{atom.cst.decl.name}' is rigid: it has no time stamp (write it in a law "
                               "without one)", law.loc)
        if step > 0:
            self.stamped_later.append(law.loc)
        head_vars = list(ir.free_vars(lit).values())
        if any(isinstance(v.sort, StepSort) for v in head_vars):
            raise ResolveError("the head of a time-stamped fact may not take a step variable", law.loc)
        aux = ConstDecl(f"fact#{len(self.program.facts) + 1}", tuple(v.sort for v in head_vars), "sdFluent",
                        NamedSort("boolean"), law.loc, hidden=True, order=self.const_order)
        self.const_order += 1
        self.sig.constants[(aux.name, aux.arity)] = aux
        cst = ir.Cst(aux, tuple(head_vars), law.loc)
        cls = "action" if _is_action(atom.cst) else "static"
        head = _truth_of(lit)
        self._check_head(law, head, cls)
        self.program.laws.append(BasicLaw(cls, head, ir.Atom(cst, ir.Lit("true"), law.loc), None, None, law.loc,
                                          "fact"))
        self.program.laws.append(BasicLaw("static", None, ir.TRUE, None, None, law.loc, "exogenous",
                                          frame="exogenous", frame_cst=cst))
        self.program.facts.append(StampedRule(cst, step, _exists(body, {v.name for v in head_vars}), law.loc))

    def _mentions_actions(self, f) -> bool:
        return any(_is_action(c) for c in ir.constants_in(f))

    def _add(self, law: ast.Law, head: ir.Formula | None, body: ir.Formula, after: ir.Formula | None,
             where: ir.Formula | None, origin: str) -> None:
        if head is not None:
            head = ir.conj(_truth_of(lit) for lit in ir.conjuncts(head)) if head != ir.TRUE else head
        if head is not None and head == ir.TRUE:
            return
        if head == ir.FALSE:
            head = None
        cls = self._classify(law, head, body, after)
        if law.unless is not None:
            body, after = self._unless(law, cls, body, after, origin)
        if head is not None:
            self._check_head(law, head, cls)
        self.program.laws.append(BasicLaw(cls, head, body, after, where, law.loc, origin))

    def _classify(self, law: ast.Law, head, body, after) -> str:
        head_c = ir.constants_in(head) if head is not None else []
        body_c = ir.constants_in(body)
        after_c = ir.constants_in(after) if after is not None else []
        head_actions = [c for c in head_c if _is_action(c)]
        head_fluents = [c for c in head_c if _kind(c) in FLUENT_KINDS]
        if head_actions and head_fluents:
            raise DefinitenessError("a law's head may not mix actions and fluents", law.loc)
        if after is not None:
            if head_actions:
                raise ResolveError("a law with an action in its head cannot have an 'after' part", law.loc)
            if any(_is_action(c) for c in body_c):
                raise ResolveError("the 'if' part of a law with 'after' may not mention actions "
                                   "(they belong in the 'after' part)", law.loc)
            return "dynamic"
        if head_actions:
            return "action"
        if head is None:
            if any(_is_action(c) for c in body_c):
                return "action"
            if all(_kind(c) == "rigid" for c in body_c):
                return "rigid"
            return "static"
        if head_fluents:
            if any(_is_action(c) for c in body_c):
                raise ResolveError("a static law's 'if' part may not mention actions; use 'after', "
                                   "'always' or 'nonexecutable'", law.loc)
            return "static"
        # rigid head
        if any(_kind(c) != "rigid" for c in body_c + after_c):
            raise ResolveError("a law with a rigid constant in its head may mention only rigid constants",
                               law.loc)
        return "rigid"

    def _check_head(self, law: ast.Law, head: ir.Formula, cls: str) -> None:
        for lit in ir.conjuncts(head):
            if isinstance(lit, ir.Not) and isinstance(lit.arg, ir.Not):
                raise DefinitenessError(
                    "a doubly negated head '--F' is Cplus2ASP's choice ('F may hold'); CCALC has no such head: "
                    "write 'default F' (with the same 'if'/'after' parts)", law.loc)
            atom = lit.arg if isinstance(lit, ir.Not) else lit
            if isinstance(atom, ir.Truth):
                continue
            if not isinstance(atom, ir.Atom):
                raise DefinitenessError(
                    f"the head of this law is not a literal or conjunction of literals (found {_describe(atom)}); "
                    "the causal theory would not be definite", law.loc)
            if isinstance(lit, ir.Not) and not _atom_boolean(atom):
                raise DefinitenessError("a negated non-Boolean atom -(c=v) cannot be a head; "
                                        "the causal theory would not be definite", law.loc)
            if isinstance(atom.cst, ir.Var):
                continue
            kind = atom.cst.decl.kind
            if cls == "dynamic" and kind in ("sdFluent", "rigid"):
                raise ResolveError(f"'{atom.cst.decl.name}' is a {kind}; it cannot be the head of a law "
                                   "with 'after'", law.loc)
            if kind in ("additiveFluent", "additiveAction"):
                raise ResolveError(f"'{atom.cst.decl.name}' is additive; it changes only by "
                                   "'increments'/'decrements' laws", law.loc)

    def _unless(self, law: ast.Law, cls: str, body, after, origin: str):
        scope = _Scope(law=law.kind)
        target = "after" if cls == "dynamic" else "if"
        kind = {"dynamic": "abAction", "action": "abAction", "static": "sdFluent", "rigid": "rigid"}[cls]
        ab = self._ab_atom(law.unless, scope, kind)  # type: ignore[arg-type]
        neg = ir.Not(ab)
        if target == "after":
            return body, ir.conj((after or ir.TRUE, neg))
        return ir.conj((body, neg)), after

    def _ab_atom(self, e: ast.Expr, scope: _Scope, kind: str) -> ir.Atom:
        """The atom ``ab(args)=true`` of ``unless ab(args)``.  An undeclared ``ab`` is declared
        Boolean, of ``kind`` (the one the law's class calls for).  The first ``unless`` that names
        a constant gives it ``default -ab`` (macros.std, each ``unless`` macro's first use: the
        ``process_..._abLabel`` side effect and ``default -(#4)``), declared or not: an
        ``abAction`` of ``:- constants`` that no ``unless`` names gets no default, as in CCALC."""
        e = self._expand(e)
        if not isinstance(e, ast.Name) or e.name[0].isupper():
            raise ResolveError("'unless' takes an abnormality atom ab(args)", e.loc)
        decl = self.sig.lookup(e.name, len(e.args))
        args = tuple(self._term_x(a, scope) for a in e.args)
        if decl is None:
            sorts = tuple(self._sort_of_arg(a, e) for a in args)
            decl = ConstDecl(e.name, sorts, kind, NamedSort("boolean"), e.loc, auto_ab=True,
                             order=self.const_order)
            self.const_order += 1
            self.sig.constants[(e.name, len(args))] = decl
        elif not _is_boolean(decl.domain):
            raise SortError(f"'{e.name}' in 'unless' must be Boolean", e.loc)
        if (decl.name, decl.arity) not in self.defaulted:
            self.defaulted.add((decl.name, decl.arity))
            decl.abnormal = True
            v = [ir.Var(f"_ab{i}", s, e.loc) for i, s in enumerate(decl.argsorts)]
            neg = ir.Not(ir.Atom(ir.Cst(decl, tuple(v), e.loc), ir.Lit("true"), e.loc))
            cls = "action" if decl.is_action else "rigid" if decl.kind == "rigid" else "static"
            self.program.laws.append(BasicLaw(cls, neg, neg, None, None, e.loc, "default"))
        return ir.Atom(ir.Cst(decl, args, e.loc), ir.Lit("true"), e.loc)

    def _sort_of_arg(self, a: ir.Term, e: ast.Name) -> SortExpr:
        if isinstance(a, ir.Var):
            return a.sort
        if isinstance(a, ir.Lit):
            for name, info in self.sig.sorts.items():
                if a.value in info.members:
                    return NamedSort(name)
            if isinstance(a.value, int):
                return RangeSort(a.value, a.value)
        raise ResolveError("the arguments of an undeclared abnormality must be variables or objects", e.loc)

    def _frame_law(self, law: ast.Law, scope: _Scope) -> None:
        items = _split_list(self._expand(law.head))  # type: ignore[arg-type]
        if_ = self._formula(law.if_, scope) if law.if_ is not None else ir.TRUE
        after = self._formula(law.after, scope) if law.after is not None else None
        where = self._formula(law.where, scope) if law.where is not None else None
        for item in items:
            neg = isinstance(item, ast.Unary) and item.op == "not"
            t = self._term_x(item.arg if neg else item, scope)  # type: ignore[union-attr]
            if not isinstance(t, ir.Cst) or neg:
                raise ResolveError(f"'{law.kind}' takes constants, e.g. '{law.kind} c(X)'", item.loc)
            if any(ir.constants_in(a) for a in t.args):
                raise ResolveError(f"the arguments of '{t.decl.name}' in '{law.kind}' may not mention constants",
                                   item.loc)
            kind = t.decl.kind
            if law.kind == "exogenous":
                if after is not None:
                    raise ResolveError("'exogenous c' takes no 'after' part", law.loc)
                cls = "rigid" if kind == "rigid" else ("action" if t.decl.is_action else "static")
                body, aft = if_, None
            else:
                if not t.decl.is_fluent:
                    raise ResolveError(f"'{law.kind}' applies to fluents; '{t.decl.name}' is a {kind}", item.loc)
                if kind in ("sdFluent", "additiveFluent"):
                    raise ResolveError(f"'{law.kind}' cannot apply to the {kind} '{t.decl.name}'", item.loc)
                cls = "dynamic"
                if law.kind == "inertial":   # caused c=v if c=v after c=v & G
                    body, aft = ir.TRUE, ir.conj((after or ir.TRUE, if_))
                else:                        # rigid c: caused false if -(c=v) & G after c=v & H
                    body, aft = if_, after or ir.TRUE
            law_obj = BasicLaw(cls, None, body, aft, where, law.loc, law.kind, frame=law.kind, frame_cst=t)
            if law.unless is not None:
                b, a = self._unless(law, cls, law_obj.body, law_obj.after, law.kind)
                law_obj = BasicLaw(cls, None, b, a, where, law.loc, law.kind, frame=law.kind, frame_cst=t)
            self.program.laws.append(law_obj)

    def _increment_law(self, law: ast.Law, scope: _Scope, cond: ir.Formula, where) -> None:
        target = self._term(law.head, scope)  # type: ignore[arg-type]
        if not isinstance(target, ir.Cst) or target.decl.kind not in ("additiveFluent", "additiveAction"):
            raise SortError("'increments'/'decrements' apply to additive constants", law.head.loc)  # type: ignore
        if any(ir.constants_in(a) for a in target.args):
            raise ResolveError(f"the arguments of '{target.decl.name}' in 'increments' may not mention constants",
                               law.head.loc)  # type: ignore[union-attr]
        action = self._formula(law.action, scope)  # type: ignore[arg-type]
        if not self._mentions_actions(action):
            raise ResolveError("the left side of 'increments' must be an action", law.loc)
        amount = self._term(law.amount, scope)  # type: ignore[arg-type]
        if ir.constants_in(amount):
            raise ResolveError("the amount of 'increments' may not mention constants", law.amount.loc)  # type: ignore
        if law.unless is not None:
            ab = self._ab_atom(law.unless, scope, "abAction")
            cond = ir.conj((cond, ir.Not(ab)))
        if law.after is not None:
            raise ResolveError("'increments' takes no 'after' part", law.loc)
        self.program.increments.append(IncrementLaw(action, target, amount, cond, where, law.decrement, law.loc))


def _truth_of(lit: ir.Formula) -> ir.Formula:
    """A head literal with ``-true``/``-false`` read as ``false``/``true``."""
    if isinstance(lit, ir.Not) and isinstance(lit.arg, ir.Truth):
        return ir.Truth(not lit.arg.value)
    return lit


def _split_list(e: ast.Expr) -> list[ast.Expr]:
    if isinstance(e, ast.Binary) and e.op in (",", "&"):
        return _split_list(e.left) + _split_list(e.right)
    return [e]


def _has_stamp(e) -> bool:
    if isinstance(e, ast.Stamp):
        return True
    if isinstance(e, ast.Binary):
        return _has_stamp(e.left) or _has_stamp(e.right)
    if isinstance(e, ast.Unary):
        return _has_stamp(e.arg)
    if isinstance(e, ast.Quant):
        return _has_stamp(e.body)
    return False


def _stamped_literals(f: ir.Formula, step: int | None, law: ast.Law) -> list[tuple[int | None, ir.Formula]]:
    """The head of a time-stamped fact as ``(step, literal)`` pairs (``step`` None: a conjunct
    without constants, a condition), the stamps distributed over conjunctions and negations
    (macros.std: ``#1: #2 & #3 -> (#1: #2) & (#1: #3)``, ``#1: -(#2) -> -((#1: #2))``) and an
    inner stamp winning (``#1: #2: #3 -> #2: #3``)."""
    if isinstance(f, ir.StampF):
        t = f.time
        if not isinstance(t, ir.Lit) or not isinstance(t.value, int):
            raise ResolveError("the time stamp of a fact's head is an integer (a step variable or "
                               "'maxstep' is not taken there)", law.loc)
        return _stamped_literals(f.body, t.value, law)
    if isinstance(f, ir.And):
        return [pair for item in f.items for pair in _stamped_literals(item, step, law)]
    if isinstance(f, ir.Not) and isinstance(f.arg, ir.StampF):
        return _stamped_literals(ir.StampF(f.arg.time, ir.Not(f.arg.body), f.arg.loc), step, law)
    if not ir.constants_in(f) and not ir.mentions(f, (ir.StampF,)):
        return [(None, f)]
    atom = f.arg if isinstance(f, ir.Not) else f
    if not isinstance(atom, ir.Atom):
        raise DefinitenessError(
            f"the head of a time-stamped fact is a literal ('t: c=v', 't: p', 't: -p'), a conjunction of them, "
            f"true or false: CCALC reads the fact as a causal rule, and {_describe(atom)} there would not be "
            "definite", law.loc)
    if step is None:
        raise ResolveError("each literal of a time-stamped fact's head needs its time stamp", law.loc)
    return [(step, f)]


def _exists(body: ir.Formula, keep) -> ir.Formula:
    """``body`` with its free variables other than ``keep`` read existentially."""
    for v in reversed(list(ir.free_vars(body).values())):
        if v.name not in keep:
            body = ir.Quant(True, v, body)
    return body


def _kind(c) -> str:
    return c.sort.kind if isinstance(c, ir.Var) else c.decl.kind  # type: ignore[union-attr]


def _is_action(c) -> bool:
    return _kind(c) in ACTION_KINDS


def _atom_boolean(atom: ir.Atom) -> bool:
    if isinstance(atom.cst, ir.Var):
        return True
    return _is_boolean(atom.cst.decl.domain) and atom.cst.decl.kind != "attribute"


def _describe(f) -> str:
    return {ir.Or: "a disjunction", ir.Imp: "an implication", ir.Iff: "an equivalence",
            ir.Quant: "a quantifier", ir.Cmp: "a comparison", ir.Not: "a negated formula",
            ir.ExtPred: "an external predicate"}.get(type(f), "a formula")
