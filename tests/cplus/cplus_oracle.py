"""An independent reference for the meaning of C+ action descriptions (test oracle).

A :class:`Description` is a small C+ domain held as data: sorts and objects, constants
with their kinds, variables, laws in their source forms, ``noconcurrency`` and one query.
:meth:`Description.text` writes it in CCALC's language for the project to parse;
:func:`histories` computes its meaning without any of the project's code:

1. the laws are expanded as the language reference says (C.2 abbreviations, C.3 laws
   implied by declarations, C.4 additive constants, C.6 ``unless`` with auto-declared
   abnormalities, ``default -ab`` from the first ``unless`` that names a constant) into basic
   rules ``head <= body [after H]`` and classified (static, action, fluent dynamic, rigid);
   time-stamped facts outside the query are causal rules of the steps they name (CCALC);
   chains of connectives written without parentheses are grouped by CCALC's own table of
   precedences (precedences.std: ``&`` and ``&&`` 760, ``++`` 770, ``->>`` 780, all xfy);
2. they are grounded here, by substituting every object of each variable's sort and
   filtering with ``where``;
3. the ground theory D_m is searched by brute force over assignments of every constant
   at every step (values taken from the declarations), keeping exactly the interpretations
   that are models in McCain and Turner's sense (D.1): every value is caused by a rule
   whose body holds, and no rule causes another value or fires a constraint.

The search assigns one (constant, step) cell at a time and checks each rule as soon as
every cell it reads is assigned; this only cuts branches that the definition rejects
anyway, so the result is the set of models of D_m that satisfy the query, nothing else.
The project shares nothing with this module: not the parser, not the grounder, not the
completion, not the solver.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from itertools import product

BOOL = ("true", "false")
FLUENT_KINDS = frozenset({"simpleFluent", "inertialFluent", "sdFluent", "additiveFluent"})
ACTION_KINDS = frozenset({"exogenousAction", "action", "attribute", "abAction", "additiveAction"})
INITIALLY_FREE = frozenset({"simpleFluent", "inertialFluent", "additiveFluent"})
ADDITIVE = frozenset({"additiveFluent", "additiveAction"})

# Formulas are tuples:  ("true",) ("false",) ("eq", t1, t2) ("cmp", op, t1, t2) ("not", f)
# ("and"|"or"|"imp"|"iff", f, g) ("q", "ex"|"all", var, f), and ("chain", ops, operands): the
# operands written with the operators between them and no parentheses (ops from "&", "&&",
# "++", "->>"), whose grouping is CCALC's (see chain_tree).
# Terms: ("o", object or int) ("v", name) ("c", constant name, (arg terms...)) ("+"|"-", t1, t2).
Formula = tuple
Term = tuple
TRUE: Formula = ("true",)
FALSE: Formula = ("false",)


def obj(v) -> Term:
    return ("o", v)


def cst(name: str, *args) -> Term:
    return ("c", name, tuple(args))


def atom(name: str, *args, value="true") -> Formula:
    """``name(args)=value`` (Boolean by default)."""
    return ("eq", cst(name, *args), value if isinstance(value, tuple) else obj(value))


def neg(f: Formula) -> Formula:
    return ("not", f)


def conj(*fs: Formula) -> Formula:
    fs = tuple(f for f in fs if f != TRUE)
    if not fs:
        return TRUE
    out = fs[0]
    for f in fs[1:]:
        out = ("and", out, f)
    return out


@dataclass(frozen=True)
class Const:
    """``name(arg) :: kind(domain)``; ``domain_text`` is how the domain is written (None: Boolean)."""

    name: str
    kind: str
    domain: tuple = BOOL
    domain_text: str | None = None
    arg: str | None = None
    parent: str | None = None        # an attribute's action

    @property
    def values(self) -> tuple:
        if self.kind == "attribute" or (self.kind == "abAction" and self.domain != BOOL):
            return self.domain + ("none",)
        return self.domain

    @property
    def boolean(self) -> bool:
        return self.values == BOOL


@dataclass(frozen=True)
class Law:
    """One law in its source form.

    ``form`` is one of caused, fact, default, possibly, causes, may_cause, nonexecutable,
    exogenous, inertial, rigid, constraint, always, never, impossible, increments, decrements.  ``head``
    is the caused formula (the constant term for exogenous/inertial/rigid and for the
    additive target of increments); ``action`` the A of causes/may cause/nonexecutable/
    increments; ``amount`` the N of increments.
    """

    form: str
    head: Formula | Term | None = None
    cond: Formula | None = None
    after: Formula | None = None
    action: Formula | None = None
    amount: int | None = None
    unless: Term | None = None
    where: Formula | None = None


@dataclass
class Description:
    sorts: dict[str, tuple[str, ...]]                 # sort -> its own objects, in order
    subsorts: dict[str, tuple[str, ...]] = field(default_factory=dict)
    variables: dict[str, str] = field(default_factory=dict)
    consts: list[Const] = field(default_factory=list)
    laws: list[Law] = field(default_factory=list)
    max_additive: int | None = None
    noconcurrency: bool = False
    strong: bool = False       # with noconcurrency: strong_noconcurrency
    query: list[tuple[int | str, Formula]] = field(default_factory=list)   # (step or "maxstep", F)
    facts: list[tuple[int, Formula, tuple[int, Formula] | None]] = field(default_factory=list)
    """Time-stamped facts outside the query: ``t: H if t2: G.`` as (t, H, (t2, G) or None)."""

    # ------------------------------------------------------------------ C+ text
    def text(self, maxstep: int, lo: int | None = None) -> str:
        """The description in C+, its query over ``maxstep :: lo..maxstep`` (or exactly ``maxstep``)."""
        out = []
        if self.sorts:
            items = []
            listed = {k for ks in self.subsorts.values() for k in ks}
            for s in self.sorts:
                if s in listed:
                    continue
                kids = self.subsorts.get(s, ())
                items.append(s + "".join(f" >> {k}" for k in kids) if kids else s)
            out.append(":- sorts " + "; ".join(items) + ".")
            objs = [f"{', '.join(os)} :: {s}" for s, os in self.sorts.items() if os]
            if objs:
                out.append(":- objects " + "; ".join(objs) + ".")
        if self.variables:
            out.append(":- variables " + "; ".join(f"{v} :: {s}" for v, s in self.variables.items()) + ".")
        if self.max_additive is not None:
            out.append(f":- maxAdditive :: {self.max_additive}.")
        decls = []
        for c in self.consts:
            name = c.name + (f"({c.arg})" if c.arg else "")
            if c.kind == "attribute":
                parent = self.const(c.parent)  # type: ignore[arg-type]
                of = parent.name + (f"({parent.arg})" if parent.arg else "")
                decls.append(f"{name} :: attribute({c.domain_text}) of {of}")
            elif c.kind == "rigid" and c.domain_text is not None:
                decls.append(f"{name} :: {c.domain_text}")
            else:
                decls.append(f"{name} :: {c.kind}" + (f"({c.domain_text})" if c.domain_text else ""))
        out.append(":- constants " + ";\n    ".join(decls) + ".")
        out += [law_text(law) for law in self.laws]
        for t, head, cond in self.facts:
            out.append(f"{t}: {show(head)}" + (f" if {cond[0]}: {show(cond[1])}" if cond else "") + ".")
        if self.noconcurrency:
            out.append("strong_noconcurrency." if self.strong else "noconcurrency.")
        items = [f"maxstep :: {maxstep}" if lo is None else f"maxstep :: {lo}..{maxstep}"] + [f"{t}: {show(f)}" for t, f in self.query]
        out.append(":- query\n    " + ";\n    ".join(items) + ".")
        return "\n".join(out) + "\n"

    def const(self, name: str) -> Const:
        return next(c for c in self.consts if c.name == name)


def term_text(t: Term) -> str:
    k = t[0]
    if k == "o":
        return str(t[1])
    if k == "v":
        return t[1]
    if k == "c":
        return t[1] + (f"({','.join(term_text(a) for a in t[2])})" if t[2] else "")
    return f"{term_text(t[1])}{k}{term_text(t[2])}"


_CONNECTIVE = {"and": "&", "or": "++", "imp": "->>", "iff": "<->>"}


def show(f: Formula) -> str:
    k = f[0]
    if k in ("true", "false"):
        return k
    if k == "eq":
        if f[2] == ("o", "true") and f[1][0] == "c":
            return term_text(f[1])
        return f"{term_text(f[1])}={term_text(f[2])}"
    if k == "cmp":
        return f"{term_text(f[2])} {f[1]} {term_text(f[3])}"
    if k == "not":
        g = f[1]
        # `-p` for a Boolean atom; `-(c=v)` otherwise: CCALC reads `-c=v` as `(-c)=v`
        return "-" + show(g) if g[0] == "eq" and "=" not in show(g) else f"-({show(g)})"
    if k == "q":
        quantifier = "\\/" if f[1] == "ex" else "/\\"
        return f"[{quantifier}{f[2]} | {show(f[3])}]"
    if k == "chain":
        out = [_operand(f[2][0])]
        for op, g in zip(f[1], f[2][1:]):
            out += [op, _operand(g)]
        return "(" + " ".join(out) + ")"
    return f"({show(f[1])} {_CONNECTIVE[k]} {show(f[2])})"


def _operand(f: Formula) -> str:
    """An operand of a chain: an atom as it is, anything else in parentheses (show adds them)."""
    text = show(f)
    return text if f[0] in ("eq", "true", "false", "chain", "q") or text.startswith("(") else f"({text})"


PRECEDENCE = {"&": 760, "&&": 760, "++": 770, "->>": 780}
"""CCALC's precedences.std: ``op(760, xfy, [&&, &])``, ``op(770, xfy, [++])``, ``op(780, xfy,
[->>])``.  Every one is xfy: a chain groups to the right within one precedence."""
_MEANING = {"&": "and", "&&": "and", "++": "or", "->>": "imp"}


def chain_tree(ops: tuple, operands: tuple) -> Formula:
    """How Prolog's reader groups ``o0 op1 o1 op2 o2 ...`` under CCALC's operator table: the
    operator of the highest precedence is the principal one, its leftmost occurrence for xfy."""
    if not ops:
        return operands[0]
    top = max(PRECEDENCE[o] for o in ops)
    i = next(k for k, o in enumerate(ops) if PRECEDENCE[o] == top)
    return (_MEANING[ops[i]], chain_tree(ops[:i], operands[:i + 1]), chain_tree(ops[i + 1:], operands[i + 1:]))


def law_text(law: Law) -> str:
    f = law.form
    h = law.head
    if f == "fact":
        s = show(h)  # type: ignore[arg-type]
    elif f in ("caused", "default", "constraint", "always", "never", "impossible"):
        s = f"{f} {show(h)}"  # type: ignore[arg-type]
    elif f == "possibly":
        s = f"possibly caused {show(h)}"  # type: ignore[arg-type]
    elif f in ("exogenous", "inertial", "rigid"):
        s = f"{f} {term_text(h)}"  # type: ignore[arg-type]
    elif f == "causes":
        s = f"{show(law.action)} causes {show(h)}"  # type: ignore[arg-type]
    elif f == "may_cause":
        s = f"{show(law.action)} may cause {show(h)}"  # type: ignore[arg-type]
    elif f == "nonexecutable":
        s = f"nonexecutable {show(law.action)}"  # type: ignore[arg-type]
    elif f in ("increments", "decrements"):
        s = f"{show(law.action)} {f} {term_text(h)} by {law.amount}"  # type: ignore[arg-type]
    else:
        raise ValueError(f"unknown law form {f}")
    if law.cond is not None:
        s += f" if {show(law.cond)}"
    if law.after is not None:
        s += f" after {show(law.after)}"
    if law.unless is not None:
        s += f" unless {term_text(law.unless)}"
    if law.where is not None:
        s += f" where {show(law.where)}"
    return s + "."


# ---------------------------------------------------------------------------- meaning

UNDEF = object()
Key = tuple   # (rigid, states, actions), each a frozenset of (constant text, value text)


def histories(desc: Description, maxstep: int) -> set[Key]:
    """Every history of length ``maxstep`` that answers the description's query."""
    return set(_Theory(desc).models(maxstep))


def first_histories(desc: Description, lo: int, hi: int) -> tuple[int | None, set[Key]]:
    """D.5: the first maxstep in lo..hi with a history, and every history there."""
    theory = _Theory(desc)
    for m in range(lo, hi + 1):
        found = set(theory.models(m))
        if found:
            return m, found
    return None, set()


@dataclass(frozen=True)
class _Basic:
    cls: str                      # rigid, static, action, dynamic
    head: Formula | None          # a literal, or None for a constraint (head false)
    body: Formula
    after: Formula | None
    where: Formula | None


@dataclass(frozen=True)
class _Inc:
    target: Term
    action: Formula
    amount: int
    cond: Formula
    where: Formula | None


class _Theory:
    def __init__(self, desc: Description) -> None:
        self.desc = desc
        self.consts: dict[str, Const] = {c.name: c for c in desc.consts}
        self.variables: dict[str, str] = dict(desc.variables)
        self.basic: list[_Basic] = []
        self.incs: list[_Inc] = []
        self.defaulted: set[str] = set()       # constants an `unless` gave `default -ab`
        for law in desc.laws:
            self._expand(law)
        self.ground = [(c.name, args) for c in self.consts.values() for args in self._arg_tuples(c)]

    # -------------------------------------------------------------- signature
    def objects_of(self, sort: str) -> list:
        if ".." in sort:                      # an anonymous range sort lo..hi
            lo, hi = sort.split("..")
            return list(range(int(lo), int(hi) + 1))
        out = list(self.desc.sorts.get(sort, ()))
        for k in self.desc.subsorts.get(sort, ()):
            out += [o for o in self.objects_of(k) if o not in out]
        return out

    def _arg_tuples(self, c: Const) -> list[tuple]:
        return [(o,) for o in self.objects_of(c.arg)] if c.arg else [()]

    def kind(self, name: str) -> str:
        return self.consts[name].kind

    def _constants(self, f) -> set[str]:
        out = set()
        for node in walk(f):
            if node[0] == "c":
                out.add(node[1])
        return out

    # -------------------------------------------------------------- C.2, C.6
    def _expand(self, law: Law) -> None:
        f, h, g, a = law.form, law.head, law.cond or TRUE, law.after
        w = law.where
        if f in ("increments", "decrements"):
            cond = g
            if law.unless is not None:
                cond = conj(cond, neg(self._ab(law.unless, "abAction")))
            amount = law.amount if f == "increments" else -law.amount  # type: ignore[operator]
            self.incs.append(_Inc(h, law.action, amount, cond, w))  # type: ignore[arg-type]
            return
        if f in ("exogenous", "inertial", "rigid"):
            c = self.consts[h[1]]  # type: ignore[index]
            for v in c.values:
                lit = ("eq", h, obj(v))
                if f == "exogenous":
                    self._basic(law, lit, conj(lit, g), None)
                elif f == "inertial":     # caused c=v if c=v after c=v & G & H
                    self._basic(law, lit, lit, conj(conj(lit, g), a or TRUE))
                else:                     # caused false if -(c=v) & G after c=v & H
                    self._basic(law, None, conj(neg(("eq", h, obj(v))), g), conj(lit, a or TRUE))
            return
        if f in ("caused", "fact"):
            self._basic(law, h, g, a)
        elif f in ("default", "possibly"):
            self._basic(law, h, conj(h, g), a)  # type: ignore[arg-type]
        elif f == "causes":
            if self._constants(h) & {n for n in self.consts if self.kind(n) in ACTION_KINDS}:
                self._basic(law, h, conj(law.action, g), None)  # type: ignore[arg-type]
            else:
                self._basic(law, h, TRUE, conj(law.action, g))  # type: ignore[arg-type]
        elif f == "may_cause":
            self._basic(law, h, h, conj(law.action, g))  # type: ignore[arg-type]
        elif f == "nonexecutable":
            self._basic(law, None, TRUE, conj(law.action, g))  # type: ignore[arg-type]
        elif f == "constraint":
            self._basic(law, None, conj(neg(h), g), a)  # type: ignore[arg-type]
        elif f == "always":
            self._basic(law, None, TRUE, conj(neg(h), a or TRUE))  # type: ignore[arg-type]
        elif f in ("never", "impossible"):               # Cplus2ASP's spellings of caused false if F
            self._basic(law, None, conj(h, g), a)  # type: ignore[arg-type]
        else:
            raise ValueError(f"unknown law form {f}")

    def _basic(self, law: Law, head, body, after) -> None:
        heads = _split_conj(head) if head is not None else [None]
        for hd in heads:
            if hd == TRUE:
                continue
            if hd == FALSE:
                hd = None
            cls = self._classify(hd, body, after)
            b, af = body, after
            if law.unless is not None:
                if cls == "dynamic":
                    af = conj(af, neg(self._ab(law.unless, "abAction")))
                else:
                    kind = {"action": "abAction", "static": "sdFluent", "rigid": "rigid"}[cls]
                    b = conj(b, neg(self._ab(law.unless, kind)))
            self.basic.append(_Basic(cls, hd, b, af, law.where))

    def _classify(self, head, body, after) -> str:
        acts = {n for n in self.consts if self.kind(n) in ACTION_KINDS}
        hc = self._constants(head) if head is not None else set()
        bc = self._constants(body)
        if after is not None:
            return "dynamic"
        if hc & acts:
            return "action"
        if head is None:
            if bc & acts:
                return "action"
            return "rigid" if all(self.kind(n) == "rigid" for n in bc) else "static"
        if any(self.kind(n) in FLUENT_KINDS for n in hc):
            return "static"
        return "rigid"

    def _ab(self, term: Term, kind: str) -> Formula:
        """C.6: an undeclared abnormality is declared Boolean; the first ``unless`` that names a
        constant, declared or not, gives it ``default -ab`` (CCALC's macros.std); an abAction
        that no ``unless`` names gets nothing."""
        name = term[1]
        if name not in self.consts:
            args = term[2]
            assert len(args) <= 1 and all(x[0] == "v" for x in args), "abnormality arguments: one variable"
            sort = self.variables[args[0][1]] if args else None
            self.consts[name] = Const(name, kind, arg=sort)
        if name not in self.defaulted:
            self.defaulted.add(name)
            c = self.consts[name]
            lit = neg(("eq", ("c", name, (("v", "_AB0"),) if c.arg else ()), obj("true")))
            if c.arg:
                self.variables["_AB0"] = c.arg
            cls = "action" if c.kind in ACTION_KINDS else "rigid" if c.kind == "rigid" else "static"
            self.basic.append(_Basic(cls, lit, lit, None, None))
        return ("eq", term, obj("true"))

    # -------------------------------------------------------------- grounding
    def _free(self, f, bound=frozenset()) -> list[str]:
        if f is None:
            return []
        if f[0] == "v":
            return [] if f[1] in bound else [f[1]]
        if f[0] == "q":
            return self._free(f[3], bound | {f[2]})
        out: list[str] = []
        for child in _children(f):
            for v in self._free(child, bound):
                if v not in out:
                    out.append(v)
        return out

    def _envs(self, *parts, where=None) -> Iterator[dict]:
        names: list[str] = []
        for p in (*parts, where):
            for v in self._free(p):
                if v not in names:
                    names.append(v)
        sorts = [self.objects_of(self._var_sort(v)) for v in names]
        for values in product(*sorts):
            env = dict(zip(names, values))
            if where is None or _const_eval(self._subst(where, env)):
                yield env

    def _var_sort(self, v: str) -> str:
        return self.variables[v]

    def _subst(self, f, env: dict):
        if not isinstance(f, tuple) or not f:
            return f
        k = f[0]
        if k == "v":
            return ("o", env[f[1]]) if f[1] in env else f
        if k == "q":
            parts = [self._subst(f[3], {**env, f[2]: o}) for o in self.objects_of(self._var_sort(f[2]))]
            if not parts:
                return TRUE if f[1] == "all" else FALSE
            out = parts[0]
            for p in parts[1:]:
                out = ("and" if f[1] == "all" else "or", out, p)
            return out
        if k == "c":
            return ("c", f[1], tuple(self._subst(a, env) for a in f[2]))
        if k == "o":
            return f
        if k == "chain":
            return ("chain", f[1], tuple(self._subst(g, env) for g in f[2]))
        return (k, *[self._subst(x, env) if isinstance(x, tuple) else x for x in f[1:]])

    # -------------------------------------------------------------- D_m
    def models(self, m: int) -> Iterator[Key]:
        cells: list[tuple[tuple, int | None]] = []
        pos: dict[tuple, int] = {}

        def add(gc, t):
            pos[(gc, t)] = len(cells)
            cells.append((gc, t))
        kinds = {gc: self.kind(gc[0]) for gc in self.ground}
        for gc in self.ground:
            if kinds[gc] == "rigid":
                add(gc, None)
        for t in range(m + 1):
            for gc in self.ground:
                if kinds[gc] in FLUENT_KINDS:
                    add(gc, t)
            if t < m:
                for gc in self.ground:
                    if kinds[gc] in ACTION_KINDS:
                        add(gc, t)
        n = len(cells)
        checks: list[list[Callable]] = [[] for _ in range(n + 1)]
        support: dict[int, list] = {p: [] for p in range(n)}
        comp = _Compiler(self, pos, m)

        def at(refs: set, *more: int) -> int:
            return max(refs | set(more)) if (refs or more) else 0

        def rule(head, fn, refs) -> None:
            if head is None:
                checks[at(refs)].append(lambda val, fn=fn: not fn(val))
                return
            p, v = head
            if p is None:        # a head value outside the constant's domain: 'caused false if body'
                checks[at(refs)].append(lambda val, fn=fn: not fn(val))
                return
            checks[at(refs, p)].append(lambda val, p=p, v=v, fn=fn: val[p] == v or not fn(val))
            support[p].append((v, fn, refs))

        for b in self.basic:
            for env in self._envs(b.head, b.body, b.after, where=b.where):
                head = self._subst(b.head, env)
                body = self._subst(b.body, env)
                after = self._subst(b.after, env) if b.after is not None else None
                if b.cls == "rigid":
                    fn, refs = comp.formula(body, None)
                    rule(comp.head(head, None) if head is not None else None, fn, refs)
                    continue
                steps = range(m + 1) if b.cls == "static" else range(m)
                for t in steps:
                    ht = t + 1 if b.cls == "dynamic" else t
                    fn, refs = comp.formula(body, ht)
                    if after is not None:
                        fa, ra = comp.formula(after, t)
                        fn, refs = (lambda val, f1=fn, f2=fa: f2(val) and f1(val)), refs | ra
                    rule(comp.head(head, ht) if head is not None else None, fn, refs)
        # C.3: laws implied by the declarations
        for gc in self.ground:
            c = self.consts[gc[0]]
            for v in c.values:
                lit = ("eq", ("c", gc[0], tuple(obj(x) for x in gc[1])), obj(v))
                if c.kind in INITIALLY_FREE:                      # 0: c=v <= 0: c=v
                    fn, refs = comp.formula(lit, 0)
                    rule(comp.head(lit, 0), fn, refs)
                if c.kind == "inertialFluent":
                    for t in range(m):
                        fn, refs = comp.formula(lit, t + 1)
                        fa, ra = comp.formula(lit, t)
                        rule(comp.head(lit, t + 1), lambda val, f1=fn, f2=fa: f1(val) and f2(val), refs | ra)
                if c.kind in ("exogenousAction", "attribute"):
                    for t in range(m):
                        fn, refs = comp.formula(lit, t)
                        rule(comp.head(lit, t), fn, refs)
            if c.kind == "attribute":                             # always c=none <->> -a
                parent = self.consts[c.parent]  # type: ignore[index]
                pargs = tuple(obj(x) for x in gc[1][:1 if parent.arg else 0])
                done = ("eq", ("c", parent.name, pargs), obj("true")) if parent.boolean else \
                    neg(("eq", ("c", parent.name, pargs), obj("none")))
                ax = ("iff", ("eq", ("c", gc[0], tuple(obj(x) for x in gc[1])), obj("none")), neg(done))
                for t in range(m):
                    fn, refs = comp.formula(ax, t)
                    rule(None, lambda val, fn=fn: not fn(val), refs)
        if self.desc.noconcurrency:
            # at most one Boolean action done per step; strong: a non-Boolean action whose
            # domain has none counts as done when it is not none
            acts = [(gc, "true", True) for gc in self.ground if kinds[gc] in ("exogenousAction", "action")
                    and self.consts[gc[0]].boolean]
            if self.desc.strong:
                acts += [(gc, "none", False) for gc in self.ground if kinds[gc] in ("exogenousAction", "action")
                         and not self.consts[gc[0]].boolean and "none" in self.consts[gc[0]].values]
            for i, (a1, v1, is1) in enumerate(acts):
                for a2, v2, is2 in acts[i + 1:]:
                    for t in range(m):
                        p1, p2 = pos[(a1, t)], pos[(a2, t)]
                        rule(None, lambda val, p1=p1, p2=p2, v1=v1, v2=v2, is1=is1, is2=is2:
                             (val[p1] == v1) == is1 and (val[p2] == v2) == is2, {p1, p2})
        # time-stamped facts: rules of the step they name, where that step exists (CCALC grounds
        # no rule at a step beyond maxstep; an atom of the body stamped beyond it is false)
        for t, head, cond in self.desc.facts:
            for env in self._envs(head, cond[1] if cond else None):
                for lit in _split_conj(self._subst(head, env)):
                    action = bool(self._constants(lit) & {n for n in self.consts if self.kind(n) in ACTION_KINDS})
                    if t > (m - 1 if action else m):
                        continue
                    if cond is None:
                        fn, refs = comp.formula(TRUE, t)
                    else:
                        fn, refs = comp.formula(self._subst(cond[1], env), cond[0])
                    rule(comp.head(lit, t), fn, refs)
        # C.4: additive constants are the sum of the contributions of the actions done
        incs: dict[tuple, list] = {}
        for inc in self.incs:
            for env in self._envs(inc.target, inc.action, inc.cond, where=inc.where):
                target = self._subst(inc.target, env)
                gc = (target[1], tuple(a[1] for a in target[2]))
                action = self._subst(inc.action, env)
                body = conj(action, self._subst(inc.cond, env))
                incs.setdefault(gc, []).append((show(action), inc.amount, body))
        for gc in self.ground:
            c = self.consts[gc[0]]
            if c.kind not in ADDITIVE:
                continue
            for t in range(m):
                fluent = c.kind == "additiveFluent"
                target = pos[(gc, t + 1 if fluent else t)]
                base = pos[(gc, t)] if fluent else None
                parts = []
                refs = {target} | ({base} if base is not None else set())
                for key, amount, body in incs.get(gc, []):
                    fn, r = comp.formula(body, t)
                    parts.append((key, amount, fn))
                    refs |= r
                checks[at(refs)].append(self._sum_check(target, base, parts))
                support.pop(target, None)
        for p, rules in support.items():
            def caused(val, p=p, rules=tuple((v, fn) for v, fn, _ in rules)) -> bool:
                return any(val[p] == v and fn(val) for v, fn in rules)
            checks[at(set().union(*(r for _, _, r in rules)) if rules else set(), p)].append(caused)
        # D.5: the query's items constrain the history (free variables: every instance)
        for step, f in self.desc.query:
            t = m if step == "maxstep" else step
            for env in self._envs(f):
                fn, refs = comp.formula(self._subst(f, env), t)
                checks[at(refs)].append(fn)
        domains = [self.consts[gc[0]].values for gc, _ in cells]
        texts = [_text(gc) for gc, _ in cells]
        steps = [t for _, t in cells]
        kinds_at = [kinds[gc] for gc, _ in cells]
        for val in _search(domains, checks):
            rigid = frozenset((texts[p], str(val[p])) for p in range(n) if steps[p] is None)
            states = tuple(frozenset((texts[p], str(val[p])) for p in range(n)
                                     if steps[p] == t and kinds_at[p] in FLUENT_KINDS) for t in range(m + 1))
            actions = tuple(frozenset((texts[p], str(val[p])) for p in range(n)
                                      if steps[p] == t and kinds_at[p] in ACTION_KINDS) for t in range(m))
            yield rigid, states, actions

    def _sum_check(self, target: int, base: int | None, parts: list) -> Callable:
        limit = self.desc.max_additive or 0

        def check(val) -> bool:
            fired: dict[str, set] = {}
            for key, amount, fn in parts:
                if fn(val):
                    fired.setdefault(key, set()).add(amount)
            total = val[base] if base is not None else 0
            for amounts in fired.values():
                if len(amounts) > 1:            # two laws cause different contributions
                    return False
                (a,) = amounts
                if abs(a) > limit:              # a contribution outside -maxAdditive..maxAdditive
                    return False
                total += a
            return val[target] == total
        return check


def _children(f) -> tuple:
    k = f[0]
    if k in ("o", "v", "true", "false"):
        return ()
    if k == "c":
        return f[2]
    if k == "cmp":
        return (f[2], f[3])
    if k == "q":
        return (f[3],)
    if k == "chain":
        return f[2]
    return tuple(f[1:])


def walk(f) -> Iterator[tuple]:
    if f is None:
        return
    yield f
    for child in _children(f):
        yield from walk(child)


def _split_conj(f: Formula) -> list[Formula]:
    if f[0] == "and":
        return _split_conj(f[1]) + _split_conj(f[2])
    return [f]


def _text(gc: tuple) -> str:
    name, args = gc
    return name + (f"({','.join(str(a) for a in args)})" if args else "")


def _search(domains: list[tuple], checks: list[list[Callable]]) -> Iterator[list]:
    n = len(domains)
    val: list = [None] * n
    if not all(c(val) for c in checks[n]):
        return

    def go(p: int) -> Iterator[list]:
        if p == n:
            yield val
            return
        for v in domains[p]:
            val[p] = v
            if all(c(val) for c in checks[p]):
                yield from go(p + 1)
        val[p] = None
    yield from go(0)


def _order(v) -> tuple:
    """Prolog's standard order of terms: integers < names."""
    return (0, v) if isinstance(v, int) else (1, str(v))


def _compare(op: str, x, y) -> bool:
    if op in ("<", ">", "=<", ">=") and isinstance(x, int) and isinstance(y, int):
        a, b = x, y
    else:
        a, b = _order(x), _order(y)  # type: ignore[assignment]
    return {"<": a < b, ">": a > b, "=<": a <= b, ">=": a >= b,
            "@<": a < b, "@>": a > b, "@=<": a <= b, "@>=": a >= b}[op]


def _const_eval(f) -> bool:
    fn, refs = _Compiler(None, {}, 0).formula(f, None)
    assert not refs, "a 'where' condition may not mention constants"
    return fn([])


class _Compiler:
    """Ground formulas at a step -> (closure over the assignment, positions it reads)."""

    def __init__(self, theory: _Theory | None, pos: dict, m: int) -> None:
        self.theory = theory
        self.pos = pos
        self.m = m

    def cell(self, name: str, args: tuple, t: int | None) -> int | None:
        """Where the assignment holds ``name(args)`` at step t; None if there is no such
        constant then (B.9: a query's atom stamped outside 0..maxstep is false)."""
        assert self.theory is not None
        kind = self.theory.kind(name)
        when = None if kind == "rigid" else t
        return self.pos.get(((name, args), when))

    def head(self, f: Formula, t: int | None) -> tuple[int | None, object]:
        positive = True
        if f[0] == "not":
            positive, f = False, f[1]
        assert f[0] == "eq" and f[1][0] == "c", f"not a literal head: {f}"
        name, args = f[1][1], tuple(_const_value(a) for a in f[1][2])
        value = _const_value(f[2])
        c = self.theory.consts[name]  # type: ignore[union-attr]
        if not positive:
            assert c.boolean, "a negated non-Boolean head"
            value = "false" if value == "true" else "true"
        if value not in c.values:
            return None, None
        p = self.cell(name, args, t)
        assert p is not None, f"no constant {name}{args}"
        return p, value

    def term(self, t: Term, step) -> tuple[Callable, set]:
        k = t[0]
        if k == "o":
            v = t[1]
            return (lambda val: v), set()
        if k == "c":
            name = t[1]
            subs = [self.term(a, step) for a in t[2]]
            if all(a[0] == "o" for a in t[2]):
                p = self.cell(name, tuple(a[1] for a in t[2]), step)
                if p is None:
                    return (lambda val: UNDEF), set()
                return (lambda val: val[p]), {p}
            table = {args: self.cell(name, args, step) for args in
                     (gc[1] for gc in self.theory.ground if gc[0] == name)}  # type: ignore[union-attr]
            refs = {p for p in table.values() if p is not None}
            for _, r in subs:
                refs |= r
            fns = [f for f, _ in subs]

            def nested(val):
                args = tuple(f(val) for f in fns)
                p = table.get(args)
                return UNDEF if p is None else val[p]
            return nested, refs
        if k in ("+", "-"):
            (fa, ra), (fb, rb) = self.term(t[1], step), self.term(t[2], step)
            sign = 1 if k == "+" else -1

            def arith(val):
                x, y = fa(val), fb(val)
                if type(x) is int and type(y) is int:
                    return x + sign * y
                return UNDEF
            return arith, ra | rb
        raise ValueError(f"not a ground term: {t}")

    def formula(self, f: Formula, step) -> tuple[Callable, set]:
        k = f[0]
        if k == "true":
            return (lambda val: True), set()
        if k == "false":
            return (lambda val: False), set()
        if k == "eq" or k == "cmp":
            op = "=" if k == "eq" else f[1]
            a, b = (f[1], f[2]) if k == "eq" else (f[2], f[3])
            (fa, ra), (fb, rb) = self.term(a, step), self.term(b, step)
            refs = ra | rb
            if op in ("=", "\\="):
                want = op == "="

                def eq(val):
                    x, y = fa(val), fb(val)
                    if x is UNDEF or y is UNDEF:
                        return not want            # undefined: '=' is false, '\=' is its negation
                    return (x == y) == want
                return eq, refs

            def cmp(val):
                x, y = fa(val), fb(val)
                if x is UNDEF or y is UNDEF:
                    return False
                return _compare(op, x, y)
            return cmp, refs
        if k == "not":
            g, r = self.formula(f[1], step)
            return (lambda val: not g(val)), r
        if k == "chain":
            return self.formula(chain_tree(f[1], f[2]), step)
        if k in ("and", "or", "imp", "iff"):
            (g, rg), (h, rh) = self.formula(f[1], step), self.formula(f[2], step)
            fn = {"and": lambda val: g(val) and h(val), "or": lambda val: g(val) or h(val),
                  "imp": lambda val: (not g(val)) or h(val), "iff": lambda val: g(val) == h(val)}[k]
            return fn, rg | rh
        raise ValueError(f"not a ground formula: {f}")


def _const_value(t: Term):
    fn, refs = _Compiler(None, {}, 0).term(t, None)
    assert not refs
    return fn([])
