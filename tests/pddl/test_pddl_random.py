"""Random small STRIPS problems (0-ary and unary predicates, actions with one parameter):
every plan cplus finds passes unified-planning's validator, the sequential plan is as short as a
breadth-first search's, the forall-step plan has no more steps, and no plan is found exactly
when the search finds none (then proved: the state space is small)."""
from __future__ import annotations

import itertools

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pddl_support import need_up

need_up()

OBJECTS = ("o1", "o2")
# a literal: (predicate, argument) with argument None (0-ary), "x" (the parameter) or an object
ATOMS = [("q0", None), ("q1", None), ("p0", "x"), ("p1", "x"), ("p0", "o1")]
literal = st.tuples(st.sampled_from(ATOMS), st.booleans())
action = st.tuples(st.lists(literal, max_size=2), st.lists(literal, min_size=1, max_size=3))
GROUND = [("q0", None), ("q1", None)] + [(p, o) for p in ("p0", "p1") for o in OBJECTS]


def _ground(atom, x):
    name, arg = atom
    return (name, x if arg == "x" else arg)


def shortest(actions, init, goal):
    """Breadth-first search over ground states: the length of a shortest plan, or None."""
    start = frozenset(init)
    seen = {start}
    frontier = [start]
    depth = 0
    while frontier:
        if any(all((a in s) == v for a, v in goal) for s in frontier):
            return depth
        nxt = []
        for s in frontier:
            for (pre, eff), x in itertools.product(actions, OBJECTS):
                if not all((_ground(a, x) in s) == v for a, v in pre):
                    continue
                adds = {_ground(a, x) for a, v in eff if v}
                dels = {_ground(a, x) for a, v in eff if not v}
                t = frozenset((s - dels) | adds)
                if t not in seen:
                    seen.add(t)
                    nxt.append(t)
        frontier = nxt
        depth += 1
    return None


def build(actions, init, goal):
    from unified_planning.shortcuts import BoolType, Fluent, InstantaneousAction, Not, Object, Problem, UserType
    t = UserType("t")
    objs = {o: Object(o, t) for o in OBJECTS}
    fl = {"q0": Fluent("q0", BoolType()), "q1": Fluent("q1", BoolType()),
          "p0": Fluent("p0", BoolType(), x=t), "p1": Fluent("p1", BoolType(), x=t)}
    problem = Problem("random")
    for f in fl.values():
        problem.add_fluent(f, default_initial_value=False)
    problem.add_objects(objs.values())

    def expr(atom, x):
        name, arg = atom
        return fl[name]() if arg is None else fl[name](x if arg == "x" else objs[arg])
    for i, (pre, eff) in enumerate(actions):
        a = InstantaneousAction(f"a{i}", x=t)
        x = a.parameter("x")
        for atom, v in dict(pre).items():
            a.add_precondition(expr(atom, x) if v else Not(expr(atom, x)))
        for atom, v in dict(eff).items():
            a.add_effect(expr(atom, x), v)
        problem.add_action(a)
    for name, arg in init:
        problem.set_initial_value(fl[name]() if arg is None else fl[name](objs[arg]), True)
    for (name, arg), v in goal:
        e = fl[name]() if arg is None else fl[name](objs[arg])
        problem.add_goal(e if v else Not(e))
    return problem


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(action, min_size=1, max_size=3), st.sets(st.sampled_from(GROUND)),
       st.lists(st.tuples(st.sampled_from(GROUND), st.booleans()), min_size=1, max_size=3))
def test_plans_are_valid_and_sequential_ones_shortest(actions, init, goal):
    from cplus.pddl import plan_problem
    actions = [(list(dict(pre).items()), list(dict(eff).items())) for pre, eff in actions]
    goal = list(dict(goal).items())
    best = shortest(actions, init, goal)
    problem = build(actions, init, goal)
    seq = plan_problem(problem, sequential=True)       # validated inside, or PlanInvalidError
    par = plan_problem(problem)
    if best is None:
        assert seq.status == par.status == "no_plan" and seq.proved and par.proved
        return
    assert seq.status == par.status == "found"
    assert len(seq.steps) == best and seq.optimal == "length"
    assert len(par.steps) <= best


# conditional effects: (atom, value, condition literal or None); an existential precondition
# "some object has p1" as an option of each action
cond_effect = st.tuples(st.sampled_from(ATOMS), st.booleans(), st.none() | literal)
adl_action = st.tuples(st.lists(literal, max_size=2), st.lists(cond_effect, min_size=1, max_size=3), st.booleans())


def shortest_adl(actions, init, goal):
    start = frozenset(init)
    seen = {start}
    frontier = [start]
    depth = 0
    while frontier:
        if any(all((a in s) == v for a, v in goal) for s in frontier):
            return depth
        nxt = []
        for s in frontier:
            for (pre, eff, some_p1), x in itertools.product(actions, OBJECTS):
                if not all((_ground(a, x) in s) == v for a, v in pre):
                    continue
                if some_p1 and not any(("p1", o) in s for o in OBJECTS):
                    continue
                fired = [(_ground(a, x), v) for a, v, c in eff if c is None or (_ground(c[0], x) in s) == c[1]]
                adds = {a for a, v in fired if v}
                dels = {a for a, v in fired if not v}
                t = frozenset((s - dels) | adds)
                if t not in seen:
                    seen.add(t)
                    nxt.append(t)
        frontier = nxt
        depth += 1
    return None


def build_adl(actions, init, goal):
    from unified_planning.shortcuts import Exists, Not, Variable
    problem = build([(pre, [(a, v) for a, v, _ in eff]) for pre, eff, _ in actions], init, goal)
    t = problem.user_type("t")
    fl = {f.name: f for f in problem.fluents}
    objs = {o.name: o for o in problem.all_objects}
    for i, (_pre, eff, some_p1) in enumerate(actions):
        a = problem.action(f"a{i}")
        x = a.parameter("x")
        a.clear_effects()

        def expr(atom, x=x):
            name, arg = atom
            return fl[name]() if arg is None else fl[name](x if arg == "x" else objs[arg])
        for atom, v, c in eff:
            cond = True if c is None else (expr(c[0]) if c[1] else Not(expr(c[0])))
            a.add_effect(expr(atom), v, cond)
        if some_p1:
            y = Variable("y", t)
            a.add_precondition(Exists(fl["p1"](y), y))
    return problem


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(adl_action, min_size=1, max_size=3), st.sets(st.sampled_from(GROUND)),
       st.lists(st.tuples(st.sampled_from(GROUND), st.booleans()), min_size=1, max_size=3))
def test_conditional_effects_and_quantifiers(actions, init, goal):
    from cplus.pddl import check_kind, plan_problem
    # one effect per atom and condition, as PDDL has no two effects on one atom in one action
    actions = [(list(dict(pre).items()), list({(a, c): (a, v, c) for a, v, c in eff}.values()), some)
               for pre, eff, some in actions]
    goal = list(dict(goal).items())
    best = shortest_adl(actions, init, goal)
    problem = build_adl(actions, init, goal)
    check_kind(problem)
    seq = plan_problem(problem, sequential=True)
    par = plan_problem(problem)
    if best is None:
        assert seq.status == par.status == "no_plan" and seq.proved and par.proved
        return
    assert seq.status == par.status == "found"
    assert len(seq.steps) == best
    assert len(par.steps) <= best
