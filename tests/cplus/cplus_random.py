"""Random small C+ domains for the oracle test: every law form and constant kind.

:func:`descriptions` draws a :class:`~cplus_oracle.Description` over one sort with a
subsort, parameterised and plain constants of every kind (simple, inertial, statically
determined and additive fluents, Boolean, numeric and symbolic values with ``none``, rigid
constants written both ways, exogenous and plain actions, a non-Boolean action, an
attribute, declared and auto-declared abnormalities, additive actions), laws of every
form (caused/if/after, facts, causes with fluent and action heads, may cause,
nonexecutable, default (also with after), possibly caused, exogenous, inertial with if and
after, rigid with if and after, constraint, always and never with and without after,
increments/decrements, unless on every kind of law including the frame laws, where) with formulas using
every connective, quantifiers, comparisons and arithmetic between constants and nested
constants, chains of ``&``, ``&&``, ``++`` and ``->>`` without parentheses (grouped by CCALC's
precedences), time-stamped facts outside the query (causal rules of their steps, some beyond
maxstep), a declared abAction named by an ``unless`` or by none, sometimes ``noconcurrency``,
and a query with stamped items.  Sizes are small enough for the brute-force oracle.
"""
from __future__ import annotations

from dataclasses import replace

from cplus_oracle import FALSE, TRUE, Const, Description, Law, conj, cst, neg, obj, walk
from hypothesis import strategies as st

SORTS = {"s": ("k1",), "t": ("k2",)}          # s >> t: s has k1 and k2, t has k2
SUBSORTS = {"s": ("t",)}
VARIABLES = {"X": "s", "Y": "s", "Z": "t", "Q": "s", "N": "0..2"}
ARGS = {"s": ("X", "Y", "k1", "k2"), "t": ("Z", "k2")}


class _Gen:
    def __init__(self, draw) -> None:
        self.draw = draw
        self.consts: list[Const] = []
        self.laws: list[Law] = []
        self.ab_count = 0
        self.pending: list[Law] = []       # laws that must follow the ones they refer to

    # ------------------------------------------------------------ helpers
    def pick(self, seq):
        return self.draw(st.sampled_from(list(seq)))

    def chance(self, p: float) -> bool:
        return self.draw(st.integers(0, 99)) < int(p * 100)

    def of(self, *kinds: str) -> list[Const]:
        return [c for c in self.consts if c.kind in kinds]

    def term(self, c: Const, vars_ok: bool = True):
        if c.arg is None:
            return cst(c.name)
        choices = [a for a in ARGS[c.arg] if vars_ok or a[0].islower()]
        a = self.pick(choices)
        return cst(c.name, ("v", a) if a[0].isupper() else obj(a))

    def literal(self, pool: list[Const], head: bool = False, vars_ok: bool = True):
        c = self.pick(pool)
        t = self.term(c, vars_ok)
        if c.boolean:
            lit = ("eq", t, obj("true"))
            return lit if self.chance(0.5) else neg(lit)
        lit = ("eq", t, obj(self.pick(c.values)))
        return lit if head or self.chance(0.7) else neg(lit)

    def formula(self, pool: list[Const], depth: int = 0):
        """A formula over the constants of ``pool`` (rigid constants may join in)."""
        roll = self.draw(st.integers(0, 12)) if depth < 2 else 0
        if roll <= 4:
            return self.literal(pool)
        if roll == 12:                  # `a && b ++ c ->> d`: CCALC's precedences group it
            n = self.draw(st.integers(2, 4))
            ops = tuple(self.pick(["&", "&&", "&&", "++", "->>"]) for _ in range(n - 1))
            return ("chain", ops, tuple(self.literal(pool) for _ in range(n)))
        if roll <= 8:
            op = self.pick(["and", "or", "imp", "iff"])
            return (op, self.formula(pool, depth + 1), self.formula(pool, depth + 1))
        if roll == 9:
            return neg(self.formula(pool, depth + 1))
        if roll == 10:
            qc = [c for c in pool if c.arg == "s" and c.boolean]
            if qc:
                c = self.pick(qc)
                body = ("eq", cst(c.name, ("v", "Q")), obj("true"))
                return ("q", self.pick(["ex", "all"]), "Q", body if self.chance(0.6) else neg(body))
            return self.literal(pool)
        return self.comparison(pool)

    def comparison(self, pool: list[Const]):
        """Constants inside terms (C.8): comparisons, arithmetic, nested constants."""
        nums = [c for c in pool if c.arg is None and c.domain_text and c.domain_text[0].isdigit()]
        nested_host = [c for c in pool if c.arg == "s" and c.boolean]
        syms = [c for c in pool if c.arg is None and c.domain_text in ("s", "s*")]
        kinds = (["num"] if nums else []) + (["nested"] if nested_host and syms else [])
        if not kinds:
            return self.literal(pool)
        if self.pick(kinds) == "nested":               # f(loc): f at the value of loc
            return ("eq", cst(self.pick(nested_host).name, cst(self.pick(syms).name)), obj("true"))
        left = self.pick(nums)
        a = cst(left.name)
        b = cst(self.pick(nums).name) if self.chance(0.5) else obj(self.pick(left.values))
        if self.chance(0.3):
            a = ("+", a, obj(1))
        return ("cmp", self.pick(["=", "\\=", "<", "=<", ">", ">="]), a, b)

    # ------------------------------------------------------------ declarations
    def declare(self) -> None:
        add = self.consts.append
        for i in range(self.draw(st.integers(1, 3))):
            kind = self.pick(["inertialFluent", "simpleFluent", "sdFluent"])
            arg = self.pick([None, None, "s", "t"])
            add(Const(f"f{i}", kind, arg=arg))
        if self.chance(0.35):
            add(Const("v", self.pick(["inertialFluent", "simpleFluent", "sdFluent"]), (0, 1, 2), "0..2"))
        if self.chance(0.25):
            star = self.chance(0.5)
            add(Const("loc", self.pick(["inertialFluent", "sdFluent"]),
                      ("k1", "k2", "none") if star else ("k1", "k2"), "s*" if star else "s"))
        if self.chance(0.3):
            if self.chance(0.5):
                add(Const("r", "rigid", (0, 1), "0..1"))
            else:
                add(Const("rb", "rigid"))
        for i in range(self.draw(st.integers(1, 2))):
            add(Const(f"a{i}", self.pick(["exogenousAction", "exogenousAction", "action"]),
                      arg=self.pick([None, None, "s"])))
        if self.chance(0.25):
            a0 = self.consts[[c.name for c in self.consts].index("a0")]
            add(Const("amt", "attribute", (1, 2), "1..2", arg=a0.arg, parent="a0"))
        if self.chance(0.2):
            add(Const("e", "exogenousAction", (0, 1), "0..1"))
        if self.chance(0.15):
            add(Const("go", self.pick(["exogenousAction", "action"]), ("k1", "k2", "none"), "s*"))
        if self.chance(0.2):
            add(Const("ab", "abAction"))
        if self.chance(0.25):
            add(Const("n", "additiveFluent", (0, 1, 2, 3), "0..3"))
        if self.chance(0.15):
            add(Const("g", "additiveAction", (0, 1, 2, 3), "0..3"))

    # ------------------------------------------------------------ pools
    @property
    def fluents(self) -> list[Const]:          # what static formulas may read
        return self.of("inertialFluent", "simpleFluent", "sdFluent", "additiveFluent", "rigid")

    @property
    def everything(self) -> list[Const]:       # what 'after' parts and action laws may read
        return self.fluents + self.of("exogenousAction", "action", "attribute", "abAction")

    @property
    def bool_actions(self) -> list[Const]:
        return [c for c in self.of("exogenousAction", "action") if c.boolean]

    def action_formula(self):
        a = self.literal(self.bool_actions)
        if a[0] == "not" or self.chance(0.2):         # 'causes' needs something done: -a & b
            a = conj(a, self.literal(self.bool_actions))
            if a[1][0] == "not" and a[2][0] == "not":
                a = ("and", a[1][1], a[2])
        return a

    # ------------------------------------------------------------ laws
    def law(self) -> None:
        static_heads = self.of("inertialFluent", "simpleFluent", "sdFluent")
        dyn_heads = self.of("inertialFluent", "simpleFluent")
        act_heads = [c for c in self.of("action", "exogenousAction", "abAction") if c.boolean]
        rigid = self.of("rigid")
        additive = self.of("additiveFluent", "additiveAction")
        forms = ["static", "fact", "default", "constraint", "never", "always", "nonexecutable",
                 "action_caused", "action_causes", "exogenous", "conj_head", "false_head"]
        if dyn_heads:
            forms += ["dynamic", "causes", "may_cause", "default_after", "possibly", "constraint_after",
                      "inertial", "inertial_if", "inertial_if", "inertial_after", "rigid_law", "conj_dynamic",
                      "always_after", "never_after"]
            if any(c.name == "v" for c in dyn_heads):
                forms.append("arith_head")
        if rigid:
            forms += ["rigid_caused", "rigid_frame"]
        if additive:
            forms += ["increments", "increments"]
        form = self.pick(forms)
        F, E = self.fluents, self.everything
        law: Law
        cls = "static"
        if form == "static":
            law = Law("caused", self.literal(static_heads, head=True),
                      cond=self.formula(F) if self.chance(0.8) else None)
        elif form == "fact":             # F.  or  F if G.
            law = Law("fact", self.literal(static_heads, head=True),
                      cond=self.formula(F) if self.chance(0.4) else None)
        elif form == "exogenous":        # exogenous c if G: a fluent, a plain action or a rigid
            pool = static_heads + self.of("action") + self.of("rigid")
            c = self.pick(pool)
            cls = {"action": "action", "rigid": "rigid"}.get(c.kind, "static")
            pool_g = {"action": E, "rigid": self.of("rigid")}.get(c.kind, F)
            law = Law("exogenous", self.term(c), cond=self.formula(pool_g) if self.chance(0.6) else None)
            cls = "frame"
        elif form == "conj_head":        # caused F1 & F2 if G: two laws in one
            law = Law("caused", conj(self.literal(static_heads, head=True), self.literal(static_heads, head=True)),
                      cond=self.formula(F) if self.chance(0.7) else None)
        elif form == "false_head":       # caused false if G / caused true
            law = Law("caused", FALSE if self.chance(0.8) else TRUE, cond=self.formula(F))
        elif form == "default":
            law = Law("default", self.literal(static_heads, head=True),
                      cond=self.formula(F) if self.chance(0.3) else None)
        elif form == "constraint":
            law = Law("constraint", self.formula(F))
        elif form == "never":
            law = Law(self.pick(["never", "impossible"]), self.formula(F))
        elif form == "always":
            law, cls = Law("always", self.formula(E)), "dynamic"
        elif form == "always_after":     # always F after H: F's actions at the step H is read at
            law, cls = Law("always", self.formula(E), after=self.formula(F)), "dynamic"
        elif form == "never_after":      # never F after H: caused false if F after H
            law, cls = Law(self.pick(["never", "impossible"]), self.formula(F), after=self.formula(E)), "dynamic"
        elif form == "nonexecutable":
            law, cls = Law("nonexecutable", action=self.action_formula(),
                           cond=self.formula(F) if self.chance(0.6) else None), "dynamic"
        elif form == "action_caused":
            law, cls = Law("caused", self.literal(act_heads, head=True), cond=self.formula(E)), "action"
        elif form == "action_causes":
            law, cls = Law("causes", self.literal(act_heads, head=True), action=self.action_formula(),
                           cond=self.formula(F) if self.chance(0.4) else None), "action"
        elif form == "dynamic":
            law, cls = Law("caused", self.literal(dyn_heads, head=True),
                           cond=self.formula(F) if self.chance(0.4) else None, after=self.formula(E)), "dynamic"
        elif form == "causes":
            law, cls = Law("causes", self.literal(dyn_heads, head=True), action=self.action_formula(),
                           cond=self.formula(E) if self.chance(0.5) else None), "dynamic"
        elif form == "may_cause":
            law, cls = Law("may_cause", self.literal(dyn_heads, head=True), action=self.action_formula(),
                           cond=self.formula(F) if self.chance(0.3) else None), "dynamic"
        elif form in ("default_after", "possibly"):
            law, cls = Law("default" if form == "default_after" else "possibly",
                           self.literal(dyn_heads, head=True), after=self.formula(E),
                           cond=self.formula(F) if self.chance(0.3) else None), "dynamic"
        elif form == "constraint_after":
            law, cls = Law("constraint", self.formula(F), after=self.formula(E)), "dynamic"
        elif form == "inertial":
            law, cls = Law("inertial", self.term(self.pick(dyn_heads))), "frame"
        elif form == "inertial_if":      # inertial c if G: G at the state before (and the actions)
            simple = [c for c in dyn_heads if c.kind == "simpleFluent"]   # (an inertial one is already)
            law, cls = Law("inertial", self.term(self.pick(simple or dyn_heads)),
                           cond=self.formula(F if self.chance(0.6) else E)), "frame"
        elif form == "inertial_after":   # inertial c if G after H: G at the new state, H at the old
            law, cls = Law("inertial", self.term(self.pick(dyn_heads)),
                           cond=self.formula(F) if self.chance(0.5) else None, after=self.formula(E)), "frame"
        elif form == "conj_dynamic":     # caused F1 & F2 after H
            law, cls = Law("caused", conj(self.literal(dyn_heads, head=True), self.literal(dyn_heads, head=True)),
                           after=self.formula(E)), "dynamic"
        elif form == "rigid_law":        # rigid c [if G] [after H]
            law, cls = Law("rigid", self.term(self.pick(dyn_heads)),
                           cond=self.formula(F) if self.chance(0.4) else None,
                           after=self.formula(E) if self.chance(0.3) else None), "frame"
        elif form == "arith_head":     # caused v=N+1 after v=N & A: N=2 leaves the domain (C.7)
            law = Law("caused", ("eq", cst("v"), ("+", ("v", "N"), obj(1))),
                      after=conj(("eq", cst("v"), ("v", "N")), self.action_formula()),
                      where=("cmp", "<", ("v", "N"), obj(2)) if self.chance(0.5) else None)
            cls = "dynamic"
        elif form == "rigid_caused":
            c = self.pick(rigid)
            law = self.pick([Law("caused", self.literal([c], head=True), cond=self.formula(rigid)),
                             Law("default", self.literal([c], head=True)),
                             Law("constraint", self.formula(rigid)),
                             Law("fact", self.literal([c], head=True))])
            cls = "rigid"
        elif form == "rigid_frame":
            law, cls = Law("exogenous", self.term(self.pick(rigid))), "frame"
        else:                          # increments / decrements
            target = self.pick(additive)
            cond = self.formula(F + self.of("exogenousAction", "action")) if self.chance(0.4) else None
            law = Law(self.pick(["increments", "increments", "decrements"]), cst(target.name),
                      action=("eq", self.term(self.pick(self.bool_actions)), obj("true")),
                      amount=self.draw(st.integers(1, 3)), cond=cond)
            cls = "dynamic"
        rigid_names = {c.name for c in rigid}
        if cls == "static" and all(n[1] in rigid_names for part in (law.head, law.cond)
                                   for n in walk(part) if n[0] == "c"):
            cls = "rigid"
        law = self.where_and_unless(law, cls)
        if cls in ("dynamic", "action") and law.unless is None and self.of("abAction") and self.chance(0.3):
            law = replace(law, unless=cst("ab"))    # the declared abAction, named by an unless
        self.laws.append(law)

    def where_and_unless(self, law: Law, cls: str) -> Law:
        free = {n[1] for part in (law.head, law.cond, law.after, law.action) for n in walk(part)
                if n[0] == "v"}
        if law.where is None and self.chance(0.4):
            if {"X", "Y"} <= free:
                law = replace(law, where=("cmp", self.pick(["\\=", "@<"]), ("v", "X"), ("v", "Y")))
            elif "X" in free:
                law = replace(law, where=("cmp", self.pick(["=", "\\="]), ("v", "X"), obj("k2")))
        if cls == "frame" and self.chance(0.2):      # exogenous/inertial/rigid c ... unless ab
            cls = self.frame_class(law)
        elif cls == "frame" or law.head == TRUE or not self.chance(0.3):   # (caused true: no law at all)
            return law
        name = f"ab{self.ab_count}"
        self.ab_count += 1
        args = (("v", "X"),) if "X" in free and self.chance(0.5) else ()
        law = replace(law, unless=("c", name, args))
        if self.chance(0.6):       # something sometimes causes the abnormality
            self.cause_ab(name, args, cls)
        return law

    def frame_class(self, law: Law) -> str:
        """The class of the basic laws a frame law stands for (which kind its abnormality is)."""
        if law.form != "exogenous":
            return "dynamic"
        kind = next(c.kind for c in self.consts if c.name == law.head[1])  # type: ignore[index]
        return {"action": "action", "rigid": "rigid"}.get(kind, "static")

    def cause_ab(self, name: str, args: tuple, cls: str) -> None:
        head = ("eq", ("c", name, args), obj("true"))
        if cls in ("dynamic", "action"):       # an abAction: caused by what is done
            body = self.formula(self.everything)
            if not any(n[0] == "c" and n[1] in {c.name for c in self.of(
                    "exogenousAction", "action", "attribute", "abAction")} for n in walk(body)):
                body = conj(body, self.literal(self.bool_actions))
            self.pending.append(Law("caused", head, cond=body))
        elif cls == "static":
            self.pending.append(Law("caused", head, cond=self.formula(self.of(
                "inertialFluent", "simpleFluent", "sdFluent"))))
        elif cls == "rigid":
            self.pending.append(Law("caused", head, cond=self.formula(self.of("rigid"))))

    # ------------------------------------------------------------ support
    def support(self) -> None:
        """Laws that give most domains models: defaults for what needs a cause (not the
        plain inertia that would hide an `inertial c if G`)."""
        conditional = {law.head[1] for law in self.laws
                       if law.form == "inertial" and (law.cond is not None or law.after is not None)}
        for c in self.consts:
            every = cst(c.name, *([("v", "X" if c.arg == "s" else "Z")] if c.arg else []))
            lit = ("eq", every, obj("true" if c.boolean else self.pick(c.values)))
            if c.kind == "action" and self.chance(0.85):
                self.laws.append(Law("default", neg(lit) if c.boolean else lit))
            elif c.kind == "sdFluent" and self.chance(0.85):
                self.laws.append(Law("default", self.pick([lit, neg(lit)]) if c.boolean else lit))
            elif c.kind == "simpleFluent" and c.name not in conditional and self.chance(0.7):
                self.laws.append(Law("inertial", every))
            elif c.kind == "rigid" and self.chance(0.85):
                self.laws.append(Law("exogenous", every))
            elif c.kind == "abAction" and self.chance(0.5):    # (no default unless an unless names it)
                self.laws.append(Law("default", neg(lit)))

    def facts(self) -> list:
        """Time-stamped facts outside the query: `t: L.`, `t: L1 & L2.`, `t: L if t2: G.`, with a
        fluent or an action head, at steps up to 2 (beyond a smaller maxstep: no rule then)."""
        out: list = []
        heads = self.of("inertialFluent", "simpleFluent", "sdFluent")
        for _ in range(self.draw(st.integers(0, 2)) if self.chance(0.5) else 0):
            acting = self.bool_actions and self.chance(0.25)
            pool = self.bool_actions if acting else heads
            t = self.draw(st.integers(0, 1 if acting else 2))
            head = self.literal(pool, head=True)
            if not acting and self.chance(0.2):
                head = conj(head, self.literal(pool, head=True))
            cond = None
            if self.chance(0.5):
                cond = (self.draw(st.integers(0, 2)), self.formula(self.fluents))
            out.append((t, head, cond))
        return out

    def query(self, m: int) -> list:
        items = []
        for _ in range(self.draw(st.integers(0, 2))):
            step = self.draw(st.integers(0, m))
            if step < m and self.chance(0.3):
                items.append((step, self.literal(self.bool_actions)))
            else:
                pool = self.of("inertialFluent", "simpleFluent", "sdFluent", "additiveFluent")
                f = self.formula(pool) if self.chance(0.3) else self.literal(pool)
                items.append(("maxstep" if step == m and self.chance(0.5) else step, f))
        return items


@st.composite
def descriptions(draw, max_maxstep: int = 2):
    """``(description, maxstep)``."""
    g = _Gen(draw)
    g.declare()
    for _ in range(draw(st.integers(1, 6))):
        g.law()
    g.laws += g.pending
    g.support()
    m = draw(st.integers(0, max_maxstep))
    additive = any(c.kind in ("additiveFluent", "additiveAction") for c in g.consts)
    noconcurrency = g.chance(0.2)
    desc = Description(sorts=dict(SORTS), subsorts=dict(SUBSORTS), variables=dict(VARIABLES),
                       consts=g.consts, laws=g.laws, max_additive=2 if additive else None,
                       noconcurrency=noconcurrency, strong=noconcurrency and g.chance(0.5), query=g.query(m),
                       facts=g.facts())
    return desc, m

