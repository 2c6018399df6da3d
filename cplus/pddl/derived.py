"""PDDL 2.2 derived predicates (``:derived-predicates``): the rules, their strata, and an
explicit-state check of plans.

unified-planning 1.3 has no derived predicates (no axioms in its problems, no ``(:derived`` in
its reader): :mod:`cplus.pddl.read` has its reader parse each rule's body as the precondition
of a stand-in action and keeps the rules here, beside the problem (:func:`rules_of`).

A derived atom holds in a state exactly when the least fixpoint of the rules says so, stratum
by stratum: the rules may use a derived predicate negatively only where it does not depend on
the head (stratified negation, as PDDL 2.2 requires). :func:`check_plan` simulates a plan on
explicit states with that fixpoint computed by plain iteration: it shares nothing with the C+
translation (whose recursive strata are unfolded into layers) and stands in for
unified-planning's validator, which cannot read these problems.
"""
from __future__ import annotations

import itertools
from collections.abc import Iterable, Iterator
from typing import Any

from cplus.errors import Location
from cplus.pddl.errors import PddlError

__all__ = ["Rule", "Stratum", "rules_of", "attach", "strata", "check_plan", "Evaluator"]

ATTRIBUTE = "cplus_derived"


class Rule:
    """``(:derived (fluent ?params) body)``: ``fluent`` holds of the parameters' objects where
    ``body`` holds (``loc``: the head's name in the domain file)."""

    def __init__(self, fluent: Any, parameters: list[Any], body: Any, loc: Location | None = None) -> None:
        self.fluent = fluent
        self.parameters = list(parameters)
        self.body = body
        self.loc = loc


class Stratum:
    """Derived predicates (by name) defined together; ``recursive`` when one depends on itself
    (through the others or directly), which the translation unfolds into layers."""

    def __init__(self, names: list[str], recursive: bool) -> None:
        self.names = names
        self.recursive = recursive


def rules_of(problem: Any) -> tuple[Rule, ...]:
    """The derived-predicate rules :func:`cplus.pddl.read_problem` found (none for a problem
    built in Python: unified-planning has no derived predicates)."""
    return getattr(problem, ATTRIBUTE, ())


def attach(problem: Any, rules: Iterable[Rule]) -> None:
    setattr(problem, ATTRIBUTE, tuple(rules))


def occurrences(node: Any, positive: bool = True) -> Iterator[tuple[Any, bool]]:
    """The fluent expressions in a condition, each with its polarity (both for ``iff``)."""
    if node.is_fluent_exp():
        yield node, positive
        return
    if node.is_not():
        yield from occurrences(node.arg(0), not positive)
    elif node.is_implies():
        yield from occurrences(node.arg(0), not positive)
        yield from occurrences(node.arg(1), positive)
    elif node.is_iff():
        for a in node.args:
            yield from occurrences(a, True)
            yield from occurrences(a, False)
    else:
        for a in node.args:
            yield from occurrences(a, positive)


def strata(rules: Iterable[Rule]) -> list[Stratum]:
    """The derived predicates in the order they are computed (each after those it uses), grouped
    into strongly connected components of their dependencies.

    Raises:
        PddlError: at a rule's head, where a predicate depends negatively on one that depends
            on it (no stratification: PDDL 2.2 leaves such rules without meaning).
    """
    rules = list(rules)
    names = list(dict.fromkeys(r.fluent.name for r in rules))
    edges: dict[str, dict[str, set[bool]]] = {n: {} for n in names}
    where: dict[str, Location | None] = {}
    for r in rules:
        where.setdefault(r.fluent.name, r.loc)
        for occ, pos in occurrences(r.body):
            q = occ.fluent().name
            if q in edges:
                edges[r.fluent.name].setdefault(q, set()).add(pos)
    out: list[Stratum] = []
    for comp in _components(names, edges):
        members = set(comp)
        for p in comp:
            for q, signs in edges[p].items():
                if q in members and False in signs:
                    raise PddlError(f"derived predicate '{p}' depends negatively on '{q}', which depends on "
                                    f"'{p}': the rules are not stratified (PDDL 2.2 gives them no meaning)",
                                    where[p])
        recursive = len(comp) > 1 or comp[0] in edges[comp[0]]
        out.append(Stratum(comp, recursive))
    return out


def _components(nodes: list[str], edges: dict[str, dict[str, set[bool]]]) -> list[list[str]]:
    """Tarjan's strongly connected components, each after every component it reaches."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    for root in nodes:
        if root in index:
            continue
        work = [(root, iter(edges[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(edges[w])))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                out.append(sorted(comp, key=nodes.index))
    return out


Atom = tuple[str, tuple[str, ...]]


class Evaluator:
    """Conditions evaluated on explicit states (sets of true atoms ``(name, (object, ...))``),
    with the derived atoms computed by iteration to the least fixpoint, stratum by stratum."""

    def __init__(self, problem: Any) -> None:
        self.problem = problem
        self.rules = rules_of(problem)
        self.strata = strata(self.rules)
        self.derived = {r.fluent.name for r in self.rules}
        self._objects: dict[str, list[str]] = {}

    def objects(self, t: Any) -> list[str]:
        if t.name not in self._objects:
            self._objects[t.name] = [o.name for o in self.problem.objects(t)]
        return self._objects[t.name]

    def term(self, n: Any, env: dict[str, str]) -> str:
        if n.is_object_exp():
            return n.object().name
        if n.is_parameter_exp():
            return env[n.parameter().name]
        if n.is_variable_exp():
            return env[n.variable().name]
        raise ValueError(f"not a term: {n}")

    def atom(self, n: Any, env: dict[str, str]) -> Atom:
        return n.fluent().name, tuple(self.term(a, env) for a in n.args)

    def holds(self, n: Any, state: set[Atom], env: dict[str, str]) -> bool:
        if n.is_bool_constant():
            return n.bool_constant_value()
        if n.is_fluent_exp():
            return self.atom(n, env) in state
        if n.is_not():
            return not self.holds(n.arg(0), state, env)
        if n.is_and():
            return all(self.holds(a, state, env) for a in n.args)
        if n.is_or():
            return any(self.holds(a, state, env) for a in n.args)
        if n.is_implies():
            return not self.holds(n.arg(0), state, env) or self.holds(n.arg(1), state, env)
        if n.is_iff():
            return self.holds(n.arg(0), state, env) == self.holds(n.arg(1), state, env)
        if n.is_equals():
            return self.term(n.arg(0), env) == self.term(n.arg(1), env)
        if n.is_exists() or n.is_forall():
            names = [v.name for v in n.variables()]
            pools = [self.objects(v.type) for v in n.variables()]
            test = any if n.is_exists() else all
            return test(self.holds(n.arg(0), state, {**env, **dict(zip(names, objs))})
                        for objs in itertools.product(*pools))
        raise ValueError(f"cannot evaluate {n}")

    def closure(self, base: set[Atom]) -> set[Atom]:
        """``base`` (the atoms of the predicates actions change) with the derived atoms."""
        state = {a for a in base if a[0] not in self.derived}
        by_name: dict[str, list[Rule]] = {}
        for r in self.rules:
            by_name.setdefault(r.fluent.name, []).append(r)
        for stratum in self.strata:
            changed = True
            while changed:
                changed = False
                for name in stratum.names:
                    for r in by_name[name]:
                        for objs in itertools.product(*(self.objects(q.type) for q in r.parameters)):
                            atom = (name, tuple(objs))
                            if atom not in state and self.holds(r.body, state, {q.name: o for q, o in zip(r.parameters, objs)}):
                                state.add(atom)
                                changed = stratum.recursive
        return state

    def initial(self) -> set[Atom]:
        true = set()
        for fe, v in self.problem.initial_values.items():
            if fe.is_fluent_exp() and fe.fluent().type.is_bool_type() and v.is_true():
                true.add(self.atom(fe, {}))
        return self.closure(true)


def check_plan(problem: Any, steps: list[list[Any]]) -> str | None:
    """Why the linearized plan is not valid for ``problem`` (with its derived predicates), or
    None: each action's precondition holds where it starts, its effects (conditional, forall,
    a delete undone by an add of the same action) make the next state, the goal holds at the end."""
    ev = Evaluator(problem)
    state = ev.initial()
    for i, ai in enumerate(a for step in steps for a in step):
        action = ai.action
        env = {q.name: o.object().name for q, o in zip(action.parameters, ai.actual_parameters)}
        for pre in action.preconditions:
            if not ev.holds(pre, state, env):
                return f"the precondition of action {i + 1}, {ai}, does not hold"
        adds: set = set()
        dels: set = set()
        for e in action.effects:
            if not e.fluent.fluent().type.is_bool_type():
                continue                      # total-cost
            pools = [ev.objects(v.type) for v in e.forall]
            for objs in itertools.product(*pools):
                inner = {**env, **{v.name: o for v, o in zip(e.forall, objs)}}
                if ev.holds(e.condition, state, inner):
                    (adds if e.value.is_true() else dels).add(ev.atom(e.fluent, inner))
        state = ev.closure((state - dels) | adds)
    for g in problem.goals:
        if not ev.holds(g, state, {}):
            return "the goal does not hold at the end"
    return None
