"""Rules written through the rests they share (cplus.sat.factor): for random rule sets the
models over the atoms are those of the ordinary completion, one model each (the group
variables are functions of the atoms); a translation law shrinks; the planner's answers do
not change when it is used."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from pysat.solvers import Solver
from test_semantics import forced

from cplus import Domain
from cplus.ground.pf import neg
from cplus.sat import factor
from cplus.sat.cnf import ClauseBuilder

SIZES = (3, 2, 3)     # body constants' domains; the head constant has 3 values


@st.composite
def rule_sets(draw):
    def body():     # (constant, value, sign): a negated value stays in the rest
        keys = draw(st.lists(st.integers(0, len(SIZES) - 1), unique=True, min_size=2, max_size=len(SIZES)))
        return [(k, draw(st.integers(0, SIZES[k] - 1)), draw(st.sampled_from((1, 1, -1)))) for k in keys]
    rules = [(draw(st.integers(0, 2)), body()) for _ in range(draw(st.integers(1, 12)))]
    constraints = [body() for _ in range(draw(st.integers(0, 6)))]
    self_supporting = draw(st.lists(st.tuples(st.integers(0, 2), st.integers(0, SIZES[0] - 1)), max_size=2))
    return rules, constraints, self_supporting


def models(rules, constraints, self_supporting, rewrite: bool, sizes=SIZES, values=3) -> tuple[list[frozenset], int]:
    """The models projected onto the atoms, and how many clauses the encoding has: body
    constants with ``sizes`` values, a head constant with ``values``."""
    top = [0]

    def new_var() -> int:
        top[0] += 1
        return top[0]
    lits = [[new_var() for _ in range(n)] for n in sizes]
    heads = [new_var() for _ in range(values)]
    atoms = top[0]
    const_of = {x: k for k, xs in enumerate(lits) for x in xs}
    cb = ClauseBuilder(new_var)
    for xs in [*lits, heads]:
        cb.exactly_one(xs)
    bodies: dict[int, list] = {h: [] for h in heads}
    for h, body in rules:
        bodies[heads[h]].append(("&", tuple(sign * lits[k][v] for k, v, sign in body)))
    for h, v in self_supporting:       # inertia-like: the head itself in the body
        bodies[heads[h]].append(("&", (heads[h], lits[0][v])))
    if rewrite:
        bodies = dict(factor.rewrite(bodies, const_of.get, cb.lit))  # type: ignore[arg-type]
    for h in heads:
        cb.complete(h, bodies[h])
    for body in constraints:
        cb.add(neg(("&", tuple(sign * lits[k][v] for k, v, sign in body))))
    with Solver(name="glucose4", bootstrap_with=cb.clauses) as s:
        found = [frozenset(x for x in m if 0 < x <= atoms) for m in s.enum_models()]
    assert len(found) == len(set(found)), "group variables must be functions of the atoms"
    return found, len(cb.clauses)


@settings(max_examples=200, deadline=None)
@given(rule_sets())
def test_rewritten_rules_have_the_models_of_the_ordinary_completion(spec):
    rules, constraints, self_supporting = spec
    want, _ = models(rules, constraints, self_supporting, rewrite=False)
    with forced(factor):
        got, _ = models(rules, constraints, self_supporting, rewrite=True)
    assert set(got) == set(want)


def test_a_translation_law_is_written_once_per_increment_and_position():
    """``pos' = pos + spd*dur``: pairs with the same product share one variable (the
    ordinary completion: 5 clauses a rule; here 4 per position and product)."""
    rules = [(p + s * d, [(0, p, 1), (1, s, 1), (2, d, 1)])
             for s in range(4) for d in range(1, 4) for p in range(10) if p + s * d < 10]
    want, plain_size = models(rules, [], [], rewrite=False, sizes=(10, 4, 4), values=10)
    got, size = models(rules, [], [], rewrite=True, sizes=(10, 4, 4), values=10)
    assert set(got) == set(want)
    assert size < 0.8 * plain_size


CAR = """
:- sorts position; speed; duration.
:- objects 0..40 :: position; 0..6 :: speed; 1..4 :: duration.
:- variables P :: position; S :: speed; D, D1 :: duration.
:- constants pos :: inertialFluent(position); spd :: inertialFluent(speed);
   drive(duration), faster :: exogenousAction.
drive(D) causes pos = P + S * D if pos = P & spd = S where P + S * D =< 40.
nonexecutable drive(D) if pos = P & spd = S where P + S * D > 40.
nonexecutable drive(D) & drive(D1) where D < D1.
faster causes spd = S + 2 if spd = S where S + 2 =< 6.
nonexecutable faster if spd = S where S + 2 > 6.
nonexecutable faster & drive(D).
:- query maxstep :: 3; 0: pos = 0 & spd = 0.
"""


def test_the_planner_counts_the_same_histories_with_and_without_factoring(monkeypatch):
    domain = Domain.from_text(CAR)
    factored = domain.solve(solutions=0)
    size = len(Domain.from_text(CAR).templates[3].clauses)
    monkeypatch.setattr(factor, "_FROM", 10**9)
    plain = Domain.from_text(CAR).solve(solutions=0)
    assert len(factored.histories) == len(plain.histories) > 1
    assert {h.key() for h in factored.histories} == {h.key() for h in plain.histories}
    assert size < len(Domain.from_text(CAR).templates[3].clauses)
