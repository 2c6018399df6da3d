"""A unified-planning problem (classical PDDL with ADL conditions) as a C+ theory.

* every type a sort (subtypes subsorts), every object an object of its type's sort;
* every predicate a Boolean ``inertialFluent`` (so an atom no action changes keeps its value);
* every action a Boolean ``exogenousAction`` with its parameters as arguments; its
  precondition ``nonexecutable A if -(PRE)``; each effect ``A causes [-]p(..) if COND``
  (a ``forall`` effect's variables are free variables of the law; a delete effect holds only
  where no add effect of the same action adds the same atom: PDDL's add-after-delete);
* the initial state (closed world: every atom not listed false) at step 0, the goal at
  ``maxstep``;
* the concurrency: ``noconcurrency`` (``sequential``), else the forall-step semantics: two
  distinct actions may share a step unless one changes an atom the other's precondition or
  effect conditions mention (``nonexecutable A & B`` with the arguments unified, one law per
  pair of schemas and atom, so that it grounds to the interfering pairs only; where both
  actions require static atoms, one law per binding that makes them true). Any order of a
  step's actions is then a valid sequential plan.

The result keeps the names both ways: C+ names must be identifiers, PDDL names need not be.
"""
from __future__ import annotations

import math
import re
from collections.abc import Iterable
from typing import Any

from cplus.errors import Location
from cplus.parser import RESERVED
from cplus.pddl.derived import occurrences as _occurrences_of
from cplus.pddl.derived import rules_of, strata
from cplus.pddl.errors import PddlError

__all__ = ["Translation", "translate", "check_kind", "SUPPORTED_FEATURES", "QUERY_LABEL", "COST_FLUENT"]

QUERY_LABEL = "pddl"
MAX_ATOMS = 2_000_000
"""The most ground atoms (or instances of an action with a cost of its own) translated; a
larger problem is refused in one line before anything is enumerated."""
STATIC_BINDINGS = 256
"""An interference law is written once per binding of its static atoms up to this many
bindings (:meth:`_Translator.interference`); beyond, once over every instance."""
COST_FLUENT = "total_cost"

SUPPORTED_FEATURES = {
    "PROBLEM_CLASS": {"ACTION_BASED"},
    "TYPING": {"FLAT_TYPING", "HIERARCHICAL_TYPING"},
    "CONDITIONS_KIND": {"NEGATIVE_CONDITIONS", "DISJUNCTIVE_CONDITIONS", "EQUALITIES",
                        "EXISTENTIAL_CONDITIONS", "UNIVERSAL_CONDITIONS"},
    "EFFECTS_KIND": {"CONDITIONAL_EFFECTS", "FORALL_EFFECTS"},
    "QUALITY_METRICS": {"ACTIONS_COST", "PLAN_LENGTH"},
    # costs must be non-negative integers: checked instance by instance (action_cost)
    "ACTIONS_COST_KIND": {"INT_NUMBERS_IN_ACTIONS_COST", "REAL_NUMBERS_IN_ACTIONS_COST",
                          "STATIC_FLUENTS_IN_ACTIONS_COST"},
    # numeric functions only as static action costs (checked by check_kind)
    "FLUENTS_TYPE": {"INT_FLUENTS", "REAL_FLUENTS", "NUMERIC_FLUENTS"},
    "NUMBERS": {"BOUNDED_TYPES", "DISCRETE_NUMBERS", "CONTINUOUS_NUMBERS"},
    # a static cost function left undefined for some arguments: those instances are not applicable
    "INITIAL_STATE": {"UNDEFINED_INITIAL_NUMERIC"},
}
"""The unified-planning problem features the translation handles (by category); numeric
fluents only as the static functions of action costs."""

_KINDS = {"inertialFluent", "simpleFluent", "sdFluent", "additiveFluent", "exogenousAction", "action", "abAction",
          "additiveAction", "attribute", "rigid", "true", "false", "none", "min", "max", "maxAdditive", "step",
          "astep", "boolean", "afValue", "infinity", "never", "impossible", "strong_noconcurrency", "may", "cause",
          "possibly", "any", QUERY_LABEL, COST_FLUENT}


_REQUIREMENT = {"PROBLEM_TYPE": "requirement :numeric-fluents", "TIME": "requirement :durative-actions",
                "EXPRESSION_DURATION": "requirement :durative-actions",
                "FLUENTS_IN_ACTIONS_COST": "costs that change: requirement :numeric-fluents",
                "INITIAL_STATE": "an initial state not given in full", "HIERARCHICAL": "hierarchical planning"}


def check_kind(problem: Any, loc: Location | None = None) -> None:
    """Refuse a problem with a feature the translation does not handle, naming it."""
    from unified_planning.model.problem_kind import FEATURES

    present = problem.kind._features
    for category, features in FEATURES.items():
        allowed = SUPPORTED_FEATURES.get(category, set())
        for feature in features:
            if feature in present and feature not in allowed:
                needs = _REQUIREMENT.get(category) or _REQUIREMENT.get(feature)
                raise PddlError(f"not supported by cplus: {feature.lower().replace('_', ' ')} "
                                f"({category.lower().replace('_', ' ')}{', ' + needs if needs else ''})", loc)
    numeric = {f.name for f in problem.fluents if not f.type.is_bool_type()}
    if not numeric:
        return
    changed = {e.fluent.fluent().name for a in problem.actions for e in a.effects}
    used = set()
    for a in problem.actions:
        for node in [*a.preconditions, *(e.condition for e in a.effects), *(e.value for e in a.effects)]:
            used |= {f.name for f in _fluents_in(node)}
    used |= {f.name for g in problem.goals for f in _fluents_in(g)}
    bad = sorted((numeric & (changed | used)) - {"total-cost"})
    if bad:
        raise PddlError(f"numeric function '{bad[0]}' is used beyond static action costs: :numeric-fluents "
                        "is not supported by cplus", loc)


def _fluents_in(node: Any) -> Iterable[Any]:
    stack = [node]
    while stack:
        n = stack.pop()
        if n.is_fluent_exp():
            yield n.fluent()
        stack.extend(n.args)


class Translation:
    """The C+ text of a problem and the maps back to unified-planning's objects."""

    def __init__(self, problem: Any, text: str, actions: dict[str, Any], objects: dict[str, Any],
                 fluent_atoms: int, costs: dict[str, Any] | None) -> None:
        self.problem = problem
        self.text = text
        self.actions = actions          # C+ action name -> unified-planning action
        self.objects = objects          # C+ object name -> unified-planning object
        self.fluent_atoms = fluent_atoms   # ground atoms some action may change
        self.costs = costs              # C+ action name -> cost expression (None: unit costs)

    def action_instance(self, name: str, args: tuple) -> Any:
        """The unified-planning ActionInstance of a ground C+ action ``name(args)``."""
        from unified_planning.plans import ActionInstance
        return ActionInstance(self.actions[name], tuple(self.objects[str(a)] for a in args))


class _Names:
    """C+ identifiers for PDDL names: lower case, ``-`` as ``_``, reserved words and clashes
    prefixed, each name unique across categories."""

    def __init__(self) -> None:
        self.used: set[str] = set()
        self.of: dict[tuple[str, str], str] = {}

    def __call__(self, category: str, name: str) -> str:
        key = (category, name)
        if key in self.of:
            return self.of[key]
        base = re.sub(r"[^a-z0-9_]", "_", name.lower())
        if not re.match(r"[a-z]", base) or base in RESERVED or base in _KINDS:
            base = f"{category[0]}_{base}"
        out, k = base, 2
        while out in self.used:
            out, k = f"{base}_{k}", k + 1
        self.used.add(out)
        self.of[key] = out
        return out


class _Translator:
    def __init__(self, problem: Any, sequential: bool, cost_bound: int | None, max_horizon: int | None) -> None:
        self.p = problem
        self.sequential = sequential
        self.cost_bound = cost_bound
        self.max_horizon = max_horizon
        self.names = _Names()
        self.var_count: dict[str, int] = {}
        self.types = list(problem.user_types)
        self.sort = {t.name: self.names("sort", t.name) for t in self.types}
        self.obj = {o.name: self.names("object", o.name) for o in problem.all_objects}
        self.pred = {f.name: self.names("fluent", f.name) for f in problem.fluents if f.type.is_bool_type()}
        self.act = {a.name: self.names("action", a.name) for a in problem.actions}
        self.rules = rules_of(problem)
        self.derived = {r.fluent.name for r in self.rules}
        self.strata = strata(self.rules)
        self.levels: list[tuple[str, int]] = []          # the sorts of a recursive stratum's layers: name, last
        self.layers: list[tuple[str, str, Any]] = []     # layer fluent, its level sort, the derived fluent
        self._layer: dict[str, tuple[str, str]] | None = None   # while writing a layer law: name -> (layer, level)
        self._dep_memo: dict[str, tuple[set[str], bool]] = {}
        self._static: dict[str, set[tuple[str, ...]]] | None = None

    # --- sorts and variables -------------------------------------------------------------
    def ancestors(self, t: Any) -> list[str]:
        out = []
        while t is not None:
            out.append(t.name)
            t = t.father
        return out

    def objects_of(self, t: Any) -> list[Any]:
        return [o for o in self.p.all_objects if t.name in self.ancestors(o.type)]

    def var(self, t: Any, used: dict[str, int]) -> str:
        """A fresh variable of type ``t`` for one law (``used``: the law's count per sort)."""
        return self.sort_var(self.sort[t.name], used)

    def sort_var(self, s: str, used: dict[str, int]) -> str:
        used[s] = used.get(s, 0) + 1
        self.var_count[s] = max(self.var_count.get(s, 0), used[s])
        return f"{_var_prefix(s)}{used[s]}"

    # --- formulas -------------------------------------------------------------------------
    def term(self, n: Any, env: dict[str, str]) -> str:
        if n.is_parameter_exp():
            return env[n.parameter().name]
        if n.is_variable_exp():
            return env[n.variable().name]
        if n.is_object_exp():
            return self.obj[n.object().name]
        raise ValueError(f"not a term: {n}")

    def atom(self, n: Any, env: dict[str, str]) -> str:
        args = [self.term(a, env) for a in n.args]
        if self._layer and n.fluent().name in self._layer:
            name, level = self._layer[n.fluent().name]
            args.insert(0, level)
        else:
            name = self.pred[n.fluent().name]
        return f"{name}({','.join(args)})" if args else name

    def formula(self, n: Any, env: dict[str, str], used: dict[str, int]) -> str:
        if n.is_bool_constant():
            return "true" if n.bool_constant_value() else "false"
        if n.is_fluent_exp():
            return self.atom(n, env)
        if n.is_not():
            return f"-({self.formula(n.arg(0), env, used)})"
        if n.is_and():
            return "(" + " & ".join(self.formula(a, env, used) for a in n.args) + ")" if n.args else "true"
        if n.is_or():
            return "(" + " ++ ".join(self.formula(a, env, used) for a in n.args) + ")" if n.args else "false"
        if n.is_implies():
            return f"(-({self.formula(n.arg(0), env, used)}) ++ {self.formula(n.arg(1), env, used)})"
        if n.is_iff():
            a, b = self.formula(n.arg(0), env, used), self.formula(n.arg(1), env, used)
            return f"(({a} & {b}) ++ (-({a}) & -({b})))"
        if n.is_equals():
            return f"({self.term(n.arg(0), env)} = {self.term(n.arg(1), env)})"
        if n.is_exists() or n.is_forall():
            inner = dict(env)
            head = []
            for v in n.variables():
                inner[v.name] = x = self.var(v.type, used)
                head.append(("\\/" if n.is_exists() else "/\\") + x)
            return f"[{' '.join(head)} | {self.formula(n.arg(0), inner, used)}]"
        raise ValueError(f"unsupported expression {n}")

    # --- the theory ---------------------------------------------------------------------
    def head(self, a: Any, env: dict[str, str]) -> str:
        name = self.act[a.name]
        return f"{name}({','.join(env[q.name] for q in a.parameters)})" if a.parameters else name

    def action_laws(self, a: Any) -> list[str]:
        laws = []
        used: dict[str, int] = {}
        env = {q.name: self.var(q.type, used) for q in a.parameters}
        head = self.head(a, env)
        pre = [p for p in a.preconditions if not (p.is_bool_constant() and p.bool_constant_value())]
        if pre:
            body = " & ".join(self.formula(p, env, dict(used)) for p in pre)
            laws.append(f"nonexecutable {head} if -({body}).")
        adds = [e for e in a.effects if e.value.is_true()]
        for e in a.effects:
            u = dict(used)
            inner = dict(env)
            for v in e.forall:
                inner[v.name] = self.var(v.type, u)
            conds = [] if e.condition.is_true() else [self.formula(e.condition, inner, u)]
            if e.value.is_false():       # add-after-delete: no delete where an add of this action fires
                for add in adds:
                    if add.fluent.fluent() != e.fluent.fluent():
                        continue
                    u2 = dict(u)
                    env2 = dict(env)
                    bound = []
                    for v in add.forall:
                        env2[v.name] = x = self.var(v.type, u2)
                        bound.append(x)
                    eq = [f"{self.term(x, inner)} = {self.term(y, env2)}" for x, y in zip(e.fluent.args, add.fluent.args)]
                    if not add.condition.is_true():
                        eq.append(self.formula(add.condition, env2, u2))
                    guard = " & ".join(eq) or "true"
                    if bound:
                        guard = f"[{' '.join(chr(92) + '/' + x for x in bound)} | {guard}]"
                    conds.append(f"-({guard})")
            lit = ("" if e.value.is_true() else "-") + self.atom(e.fluent, inner)
            laws.append(f"{head} causes {lit}" + (f" if {' & '.join(conds)}." if conds else "."))
        return laws

    def condition_atoms(self, a: Any) -> list[tuple[Any, set[str]]]:
        """The atoms a's precondition and effect conditions mention, each with the names bound
        inside them (quantified or forall variables: wildcards when unifying)."""
        out: list[tuple[Any, set[str]]] = []

        def walk(n: Any, bound: set[str]) -> None:
            if n.is_fluent_exp():
                if n.fluent().name in self.derived:
                    for x, more in self.derived_atoms(n):
                        walk(x, bound | more)
                elif n.fluent().name in self.pred:
                    out.append((n, bound))
                return
            if n.is_exists() or n.is_forall():
                bound = bound | {v.name for v in n.variables()}
            for x in n.args:
                walk(x, bound)
        for p in a.preconditions:
            walk(p, set())
        for e in a.effects:
            walk(e.condition, {v.name for v in e.forall})
        return out

    def derived_atoms(self, n: Any) -> list[tuple[Any, set[str]]]:
        """What a derived atom's value depends on, for the interference laws: the bodies of its
        rules with the head's parameters bound to the atom's arguments (each with the names its
        body binds); where the recursion is unfolded, every atom of the predicates it rests on
        (their arguments wildcards)."""
        name = n.fluent().name
        if name not in self._dep_memo:
            deps, recursive, stack = set(), False, [name]
            while stack:
                m = stack.pop()
                if m in deps:
                    continue
                deps.add(m)
                recursive |= any(m in st.names and st.recursive for st in self.strata)
                for r in self.rules:
                    if r.fluent.name == m:
                        stack.extend(x.fluent().name for x, _ in _occurrences_of(r.body))
            self._dep_memo[name] = (deps, recursive)
        deps, recursive = self._dep_memo[name]
        em = self.p.environment.expression_manager
        if recursive:
            from unified_planning.model import Variable
            out = []
            for f in self.p.fluents:
                if f.name in deps and f.name not in self.derived:
                    vs = [Variable(f"cplus-any-{i}", q.type, self.p.environment) for i, q in enumerate(f.signature)]
                    out.append((em.FluentExp(f, [em.VariableExp(v) for v in vs]), {v.name for v in vs}))
            return out
        out = []
        for r in self.rules:
            if r.fluent.name != name:
                continue
            body = r.body.substitute({em.ParameterExp(q): a for q, a in zip(r.parameters, n.args)})
            out.append((body, set()))
        return out

    def interference_laws(self) -> list[str]:
        laws: dict[str, None] = {}
        for a in self.p.actions:
            for e in a.effects:
                for b in self.p.actions:
                    for atom, bound in self.condition_atoms(b):
                        if atom.fluent() != e.fluent.fluent():
                            continue
                        for law in self.interference(a, e, b, atom, bound):
                            laws.setdefault(law)
        return list(laws)

    def static_facts(self) -> dict[str, set[tuple[str, ...]]]:
        """The true tuples (as C+ objects) of each static predicate: one no effect and no
        derived rule changes, whose initial value therefore holds at every step."""
        if self._static is None:
            changed = {e.fluent.fluent().name for a in self.p.actions for e in a.effects}
            self._static = {f.name: set() for f in self.p.fluents
                            if f.name in self.pred and f.name not in changed and f.name not in self.derived}
            for fe, v in self.p.explicit_initial_values.items():
                if fe.is_fluent_exp() and fe.fluent().name in self._static and v.is_true():
                    self._static[fe.fluent().name].add(tuple(self.obj[x.object().name] for x in fe.args))
        return self._static

    def static_conditions(self, a: Any, env: dict[str, str]) -> list[tuple[str, list[str]]]:
        """The static atoms an action's precondition requires (top-level conjuncts), their
        arguments as the law's variables and objects."""
        facts = self.static_facts()
        out = []
        todo = list(a.preconditions)
        while todo:
            n = todo.pop()
            if n.is_and():
                todo.extend(n.args)
            elif (n.is_fluent_exp() and n.fluent().name in facts
                  and all(x.is_parameter_exp() or x.is_object_exp() for x in n.args)):
                out.append((n.fluent().name, [self.term(x, env) for x in n.args]))
        return out

    def static_bindings(self, conditions: list[tuple[str, list[str]]], sorts: dict[str, set[str]]
                        ) -> list[dict[str, str]] | None:
        """Every binding of the law's variables in ``conditions`` that makes all of them true
        (a variable only to objects of its sort, ``sorts``), or None when there are more than
        :data:`STATIC_BINDINGS`."""
        facts = self.static_facts()
        objects = set(self.obj.values())
        out: list[dict[str, str]] = []

        def rec(i: int, binding: dict[str, str]) -> None:
            if len(out) > STATIC_BINDINGS:
                return
            if i == len(conditions):
                out.append(dict(binding))
                return
            name, args = conditions[i]
            for row in facts[name]:
                new: dict[str, str] = {}
                for x, v in zip(args, row):
                    if x in objects:
                        ok = x == v
                    else:
                        have = binding.get(x, new.get(x))
                        ok = v == have if have is not None else v in sorts.get(x, objects)
                        new[x] = v
                    if not ok:
                        break
                else:
                    rec(i + 1, {**binding, **new})
        rec(0, {})
        return None if len(out) > STATIC_BINDINGS else out

    def interference(self, a: Any, e: Any, b: Any, atom: Any, bound: set[str]) -> list[str]:
        """The laws that keep ``a`` (whose effect ``e`` touches ``atom``) and ``b`` (which
        reads it) out of one step, over the pairs of instances that may share the atom. Where
        the two actions require static atoms (``next(L2, L1)`` of a fuel level), one law per
        binding of those atoms' variables that makes them true, with objects for variables:
        the other instances are never executable, and a law over all of them grounds, for a
        pair of zenotravel's flights, every fuel level five times over."""
        parent: dict[Any, Any] = {}

        def find(x: Any) -> Any:
            while parent.get(x, x) != x:
                x = parent[x]
            return x

        def token(side: str, n: Any, wild: set[str]) -> Any:
            if n.is_object_exp():
                return ("obj", n.object().name)
            name = n.parameter().name if n.is_parameter_exp() else n.variable().name
            if n.is_variable_exp() and name in wild or n.is_variable_exp() and side == "A":
                return None                        # a forall or quantified variable: anything
            return (side, name)
        for x, y in zip(e.fluent.args, atom.args):
            tx, ty = token("A", x, {v.name for v in e.forall}), token("B", y, bound)
            if tx is None or ty is None:
                continue
            rx, ry = find(tx), find(ty)
            if rx == ry:
                continue
            if rx[0] == "obj" and ry[0] == "obj":
                return []                          # two different objects: never the same atom
            if ry[0] == "obj":
                rx, ry = ry, rx
            parent[ry] = rx
        types = {("A", q.name): q.type for q in a.parameters} | {("B", q.name): q.type for q in b.parameters}
        objtype = {o.name: o.type for o in self.p.all_objects}
        classes: dict[Any, list[Any]] = {}
        for t in types:
            classes.setdefault(find(t), []).append(t)
        rep: dict[Any, str] = {}
        lowest: dict[str, Any] = {}                # a variable of the law -> its type
        used: dict[str, int] = {}
        for root, members in sorted(classes.items(), key=lambda kv: str(kv[0])):
            chain = [types[m] for m in members]
            if root[0] == "obj":
                if not all(t.name in self.ancestors(objtype[root[1]]) for t in chain):
                    return []
                rep[root] = self.obj[root[1]]
                continue
            low = max(chain, key=lambda t: len(self.ancestors(t)))
            if not all(t.name in self.ancestors(low) for t in chain):
                return []                          # disjoint types: no object is both
            rep[root] = self.var(low, used)
            lowest[rep[root]] = low
        env_a = {q.name: rep[find(("A", q.name))] for q in a.parameters}
        env_b = {q.name: rep[find(("B", q.name))] for q in b.parameters}
        conditions = self.static_conditions(a, env_a) + self.static_conditions(b, env_b)
        if conditions:
            sorts = {x: {self.obj[o.name] for o in self.objects_of(t)} for x, t in lowest.items()}
            bindings = self.static_bindings(conditions, sorts)
            cells = 1
            for x in {x for _, args in conditions for x in args if x in sorts}:
                cells *= len(sorts[x])
            if bindings is not None and len(bindings) * 4 <= cells:
                laws = [self.pair_law(a, b, {q: bind.get(x, x) for q, x in env_a.items()},
                                      {q: bind.get(x, x) for q, x in env_b.items()}) for bind in bindings]
                return [law for law in laws if law]
        law = self.pair_law(a, b, env_a, env_b)
        return [law] if law else []

    def pair_law(self, a: Any, b: Any, env_a: dict[str, str], env_b: dict[str, str]) -> str | None:
        """``nonexecutable A & B`` for instances of a and b given by their arguments."""
        ha, hb = self.head(a, env_a), self.head(b, env_b)
        where = ""
        if a is b:
            differ = [(env_a[q.name], env_b[q.name]) for q in a.parameters if env_a[q.name] != env_b[q.name]]
            if not differ:
                return None                        # the same action: it does not interfere with itself
            if not any(x in self.obj.values() and y in self.obj.values() for x, y in differ):
                where = " where " + " ++ ".join(f"{x} \\= {y}" for x, y in differ)
            if ha > hb:
                ha, hb = hb, ha
        return f"nonexecutable {ha} & {hb}{where}."

    def derived_laws(self) -> list[str]:
        """Each derived predicate a statically determined fluent, false by default, caused where
        a rule's body holds. A recursive stratum (whose completion would let atoms support
        each other in a loop) is unfolded into layers: layer 0 false, layer L+1 caused where a
        body holds with the stratum's atoms read at layer L, and the predicate equal to the
        last layer, K: the number of the stratum's ground atoms, since each layer short of the
        least fixpoint adds one at least. Every law then reads lower layers or strata only."""
        laws: list[str] = []
        by_name: dict[str, list[Any]] = {}
        for r in self.rules:
            by_name.setdefault(r.fluent.name, []).append(r)
        for stratum in self.strata:
            layer: dict[str, tuple[str, str]] = {}
            last = 0
            if stratum.recursive:
                last = sum(self.ground_atoms(by_name[n][0].fluent) for n in stratum.names)
                size = last * last
                if size > MAX_ATOMS:
                    raise PddlError(f"recursive derived predicate '{stratum.names[0]}' has {last} ground atoms "
                                    f"(with those it is defined with): unfolded into as many layers, {size} atoms, "
                                    f"more than cplus grounds ({MAX_ATOMS})", by_name[stratum.names[0]][0].loc)
                level = self.names("sort", f"{stratum.names[0]}-level")
                self.levels.append((level, last))
                for n in stratum.names:
                    layer[n] = (self.names("fluent", f"{n}-layer"), level)
                    self.layers.append((layer[n][0], level, by_name[n][0].fluent))
            for n in stratum.names:
                f = by_name[n][0].fluent
                used: dict[str, int] = {}
                xs = [self.var(q.type, used) for q in f.signature]
                head = self.pred[n] + (f"({','.join(xs)})" if xs else "")
                laws.append(f"default -{head}.")
                if not stratum.recursive:
                    for r in by_name[n]:
                        u: dict[str, int] = {}
                        env = {q.name: self.var(q.type, u) for q in r.parameters}
                        args = ",".join(env[q.name] for q in r.parameters)
                        laws.append(f"caused {self.pred[n]}{f'({args})' if args else ''} if "
                                    f"{self.formula(r.body, env, u)}.")
                    continue
                name, level = layer[n]
                lv = self.sort_var(level, used)
                laws.append(f"default -{name}({','.join([lv, *xs])}).")
                laws.append(f"caused {head} if {name}({','.join([str(last), *xs])}).")
                for r in by_name[n]:
                    u = {}
                    lv = self.sort_var(level, u)
                    env = {q.name: self.var(q.type, u) for q in r.parameters}
                    self._layer = {m: (layer[m][0], lv) for m in stratum.names}
                    try:
                        body = self.formula(r.body, env, u)
                    finally:
                        self._layer = None
                    args = ",".join([f"{lv}+1", *(env[q.name] for q in r.parameters)])
                    laws.append(f"caused {name}({args}) if {body} where {lv} < {last}.")
        return laws

    def ground_atoms(self, f: Any) -> int:
        count = 1
        for q in f.signature:
            count *= len(self.objects_of(q.type))
        return count

    def initial(self) -> str:
        total = sum(self.ground_atoms(f) for f in self.p.fluents if f.name in self.pred)
        total += sum(self.ground_atoms(f) * (last + 1) for (_, level, f) in self.layers
                     for (name, last) in self.levels if name == level)
        if total > MAX_ATOMS:
            raise PddlError(f"problem {self.p.name} has {total} ground atoms: more than cplus grounds "
                            f"({MAX_ATOMS})")
        true = set()
        for fe, v in self.p.explicit_initial_values.items():
            if fe.is_fluent_exp() and fe.fluent().name in self.pred and v.is_true():
                true.add(self.atom(fe, {}))
        lits = []
        for f in self.p.fluents:
            if f.name not in self.pred or f.name in self.derived:
                continue
            for args in _product([self.objects_of(q.type) for q in f.signature]):
                text = self.pred[f.name] + (f"({','.join(self.obj[o.name] for o in args)})" if args else "")
                lits.append(text if text in true else f"-{text}")
        return " & ".join(lits) or "true"

    def costs(self) -> dict[str, Any] | None:
        metrics = [m for m in self.p.quality_metrics if m.is_minimize_action_costs()]
        if not metrics:
            return None
        return {self.act[a.name]: metrics[0].get_action_cost(a) for a in self.p.actions}

    def cost_laws(self, costs: dict[str, Any], increments: bool) -> list[str]:
        """``A increments total_cost by K`` (with ``increments``), and ``nonexecutable A(..)``
        for each instance whose cost reads a static function the initial state leaves
        undefined (PDDL: such an instance is not applicable)."""
        laws = []
        values = self.p.initial_values
        for a in self.p.actions:
            expr = costs[self.act[a.name]]
            if not any(True for _ in _fluents_in(expr)) and not any(x.is_parameter_exp() for x in _walk(expr)):
                k = action_cost(self.p, expr, {}, values)
                if k and increments:
                    used: dict[str, int] = {}
                    env = {q.name: self.var(q.type, used) for q in a.parameters}
                    laws.append(f"{self.head(a, env)} increments {COST_FLUENT} by {k}.")
                continue
            count = math.prod(len(self.objects_of(q.type)) for q in a.parameters)
            if count > MAX_ATOMS:
                raise PddlError(f"action {a.name} has {count} instances, each with a cost of its own: more than "
                                f"cplus grounds ({MAX_ATOMS})")
            for args in _product([self.objects_of(q.type) for q in a.parameters]):
                k = action_cost(self.p, expr, {q.name: o for q, o in zip(a.parameters, args)}, values)
                env = {q.name: self.obj[o.name] for q, o in zip(a.parameters, args)}
                if k is None:
                    laws.append(f"nonexecutable {self.head(a, env)}.")
                elif k and increments:
                    laws.append(f"{self.head(a, env)} increments {COST_FLUENT} by {k}.")
        return laws

    def text(self) -> Translation:
        p = self.p
        lines = [f"% {p.name}: translated from PDDL by cplus ({'one action a step' if self.sequential else 'forall-step semantics'})"]
        costs = self.costs()
        if self.cost_bound is not None:
            lines.append(f":- maxAdditive :: {max(1, self.cost_bound)}.")
        body: list[str] = self.derived_laws()
        if self.types or self.levels:
            roots = [t for t in self.types if t.father is None]
            lines.append(":- sorts " + "; ".join([*(self.sort_tree(t) for t in roots),
                                                  *(level for level, _ in self.levels)]) + ".")
        by_type: dict[str, list[str]] = {}
        for o in p.all_objects:
            by_type.setdefault(self.sort[o.type.name], []).append(self.obj[o.name])
        for level, last in self.levels:
            by_type[level] = [f"0..{last}"]
        if by_type:
            lines.append(":- objects\n" + ";\n".join(f"  {', '.join(objs)} :: {s}" for s, objs in by_type.items()) + ".")
        for a in p.actions:
            body.extend(self.action_laws(a))
        body.append("noconcurrency." if self.sequential else "")
        if not self.sequential:
            body.extend(self.interference_laws())
        if costs is not None:
            body.extend(self.cost_laws(costs, self.cost_bound is not None))
        goal = " & ".join(self.formula(g, {}, {}) for g in p.goals) or "true"
        init = self.initial()
        if self.var_count:
            lines.append(":- variables\n" + ";\n".join(
                f"  {', '.join(f'{_var_prefix(s)}{i}' for i in range(1, n + 1))} :: {s}"
                for s, n in sorted(self.var_count.items())) + ".")
        decls = []
        for f in p.fluents:
            if f.name in self.pred:
                args = f"({','.join(self.sort[q.type.name] for q in f.signature)})" if f.signature else ""
                kind = "sdFluent" if f.name in self.derived else "inertialFluent"
                decls.append(f"  {self.pred[f.name]}{args} :: {kind}")
        for name, level, f in self.layers:
            decls.append(f"  {name}({','.join([level, *(self.sort[q.type.name] for q in f.signature)])}) :: sdFluent")
        if self.cost_bound is not None and costs is not None:
            decls.append(f"  {COST_FLUENT} :: additiveFluent(0..{max(1, self.cost_bound)})")
        for a in p.actions:
            args = f"({','.join(self.sort[q.type.name] for q in a.parameters)})" if a.parameters else ""
            decls.append(f"  {self.act[a.name]}{args} :: exogenousAction")
        if decls:
            lines.append(":- constants\n" + ";\n".join(decls) + ".")
        lines.append("")
        lines.extend(x for x in body if x)
        lines.append("")
        horizon = "infinity" if self.max_horizon is None else str(self.max_horizon)
        zero = f" & {COST_FLUENT}=0" if self.cost_bound is not None and costs is not None else ""
        lines.append(f":- query\n  label :: {QUERY_LABEL};\n  maxstep :: 0..{horizon};\n  0: {init}{zero};\n"
                     f"  maxstep: {goal}.")
        changed = {e.fluent.fluent().name for a in p.actions for e in a.effects}
        atoms = sum(self.ground_atoms(f) for f in p.fluents if f.name in self.pred and f.name in changed)
        return Translation(p, "\n".join(lines) + "\n", {v: a for a in p.actions for k, v in self.act.items()
                                                        if k == a.name},
                           {self.obj[o.name]: o for o in p.all_objects}, atoms, costs)

    def sort_tree(self, t: Any) -> str:
        children = [c for c in self.types if c.father is not None and c.father.name == t.name]
        name = self.sort[t.name]
        if not children:
            return name
        return f"{name} >> ({'; '.join(self.sort_tree(c) for c in children)})"


def changed_atoms(problem: Any) -> int:
    """The ground atoms some action may change (their count bounds the states: PROOF_ATOMS)."""
    t = _Translator(problem, True, None, None)
    changed = {e.fluent.fluent().name for a in problem.actions for e in a.effects}
    return sum(t.ground_atoms(f) for f in problem.fluents if f.name in t.pred and f.name in changed)


def _var_prefix(sort: str) -> str:
    """The variables of a sort: its name capitalized (``Block1``), with a ``V`` where the name
    ends in a digit or ``_`` (sort ``b2``: ``B2V1``), so that no two sorts' variables meet (the
    sort names are lower case)."""
    prefix = sort[0].upper() + sort[1:]
    return prefix + "V" if prefix[-1].isdigit() or prefix[-1] == "_" else prefix


def _product(pools: list[list[Any]]) -> Iterable[tuple]:
    import itertools
    return itertools.product(*pools)


def _walk(n: Any) -> Iterable[Any]:
    stack = [n]
    while stack:
        x = stack.pop()
        yield x
        stack.extend(x.args)


def action_cost(problem: Any, expr: Any, args: dict[str, Any], values: dict | None = None) -> int | None:
    """The cost of an action instance: ``expr`` with the parameters bound to objects
    (``args``: parameter name -> object) and static functions read in the initial state
    (``values``: ``problem.initial_values``, given when called in a loop); None where the
    initial state leaves a function it reads undefined."""
    if expr is None:
        return 1
    em = problem.environment.expression_manager
    subst = {}
    for x in _walk(expr):
        if x.is_parameter_exp():
            subst[x] = em.ObjectExp(args[x.parameter().name])
    ground = expr.substitute(subst) if subst else expr
    fsub = {}
    for x in _walk(ground):
        if x.is_fluent_exp():
            if values is None:
                values = problem.initial_values
            value = values.get(x)
            if value is None:
                return None
            fsub[x] = value
    value = problem.environment.simplifier.simplify(ground.substitute(fsub) if fsub else ground)
    if not (value.is_int_constant() or value.is_real_constant()):
        raise PddlError(f"the cost {expr} is not a number")
    v = value.constant_value()
    if v < 0 or int(v) != v:
        raise PddlError(f"action cost {v} of {expr}: cplus takes non-negative integer costs only")
    return int(v)


def translate(problem: Any, sequential: bool = False, cost_bound: int | None = None,
              max_horizon: int | None = None) -> Translation:
    """The C+ theory of a (checked) unified-planning problem.

    ``sequential``: one action a step (``noconcurrency``), else forall-step concurrency.
    ``cost_bound``: add the additive fluent ``total_cost`` (0..cost_bound) and each action's
    cost, for ``--minimize total-cost``.  ``max_horizon``: the query's last maxstep (None: open)."""
    return _Translator(problem, sequential, cost_bound, max_horizon).text()
