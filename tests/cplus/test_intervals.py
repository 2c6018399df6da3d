"""Constraints on runs of an integer constant written through its order (cplus.sat.intervals):
for random constraint sets the models over the atoms are those of one clause per
constraint, one model each (the order variables are functions of the atoms); a threshold
law shrinks; dead values may be stepped over; the planner's answers do not change."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from pysat.solvers import Solver
from test_semantics import forced

from cplus import Domain
from cplus.sat import intervals
from cplus.sat.cnf import ClauseBuilder

SIZES = (2, 3, 7)     # a Boolean-like constant, a small one, the integer one (values 0..6)


def models(constraints: list[list[tuple[int, int]]], order: bool, sizes=SIZES, dead: frozenset = frozenset()
           ) -> tuple[list[frozenset], int]:
    """The models over the atoms of exactly-one constants with values ``0..n-1`` (the
    values of the last one in ``dead`` false), under constraints given as lists of
    (constant, value), and the number of clauses."""
    top = [0]

    def new_var() -> int:
        top[0] += 1
        return top[0]
    lits = [[new_var() for _ in range(n)] for n in sizes]
    atoms = top[0]
    atom_of = {x: (k, v) for k, xs in enumerate(lits) for v, x in enumerate(xs)}
    cb = ClauseBuilder(new_var)
    for xs in lits:
        cb.exactly_one(xs)
    last = len(sizes) - 1
    for v in dead:
        cb.add_clause([-lits[last][v]])
    bodies = [tuple(lits[k][v] for k, v in c) for c in constraints]
    if order:
        def values_of(k: int) -> dict:
            return {v: x for v, x in enumerate(lits[k]) if not (k == last and v in dead)}
        bodies = intervals.factor_intervals(bodies, atom_of.get, values_of, cb.add_clause, new_var)
    for body in bodies:
        cb.add_clause([-x for x in body])
    with Solver(name="glucose4", bootstrap_with=cb.clauses) as s:
        found = [frozenset(x for x in m if 0 < x <= atoms) for m in s.enum_models()]
    assert len(found) == len(set(found)), "order variables must be functions of the atoms"
    return found, len(cb.clauses)


@st.composite
def constraint_sets(draw):
    def body():
        keys = draw(st.lists(st.integers(0, len(SIZES) - 1), unique=True, min_size=1, max_size=len(SIZES)))
        return [(k, draw(st.integers(0, SIZES[k] - 1))) for k in keys]
    out = [body() for _ in range(draw(st.integers(0, 10)))]
    # thresholds: the integer constant at or above a bound that depends on the others
    for a in range(SIZES[0]):
        for b in range(SIZES[1]):
            if draw(st.booleans()):
                lo = draw(st.integers(0, SIZES[2] - 1))
                out += [[(0, a), (1, b), (2, c)] for c in range(lo, SIZES[2])]
    dead = draw(st.frozensets(st.integers(0, SIZES[2] - 1), max_size=2))
    return [c for c in out if not any(k == 2 and v in dead for k, v in c)], dead


@settings(max_examples=200, deadline=None)
@given(constraint_sets())
def test_ordered_constraints_have_the_models_of_one_clause_each(spec):
    constraints, dead = spec
    want, _ = models(constraints, False, dead=dead)
    with forced(intervals):
        got, _ = models(constraints, True, dead=dead)
    assert set(got) == set(want)


def test_a_threshold_law_shrinks_to_a_clause_per_rest():
    """``-(a=i & b=j & c=v)`` for every c above ``i*j``, c in 0..99: one clause per (i, j)
    and the order of c, instead of a clause per value."""
    sizes = (4, 5, 100)
    constraints = [[(0, i), (1, j), (2, v)] for i in range(4) for j in range(5) for v in range(i * j + 1, 100)]
    want, plain = models(constraints, False, sizes=sizes)
    got, size = models(constraints, True, sizes=sizes)
    assert set(got) == set(want)
    assert size < intervals.GAIN * plain


def test_a_dead_value_does_not_break_a_run():
    """Values 0..9, 5 dead: forbidding 3, 4, 6 and 7 is one run over the live values."""
    written: list = []
    lits = {v: 100 + v for v in range(10) if v != 5}
    with forced(intervals):
        rest = intervals.factor_intervals([(1, lits[v]) for v in (3, 4, 6, 7)],
                                          lambda x: ("c", x - 100) if x >= 100 else None,
                                          lambda key: lits, written.append, iter(range(200, 300)).__next__)
    assert rest == []
    runs = [c for c in written if c[0] == -1]
    assert len(runs) == 1 and len(runs[0]) == 3


CAR = """
:- sorts position; speed; duration.
:- objects 0..150 :: position; 0..12 :: speed; 1..6 :: duration.
:- variables P :: position; S :: speed; D, D1 :: duration.
:- constants pos :: inertialFluent(position); spd :: inertialFluent(speed);
   drive(duration), faster :: exogenousAction.
drive(D) causes pos = P + S * D if pos = P & spd = S where P + S * D =< 150.
nonexecutable drive(D) if pos = P & spd = S where P + S * D > 150.
nonexecutable drive(D) if pos = P & spd = S where S > 2 & P + S * D >= 20 & P =< 30.
nonexecutable drive(D) & drive(D1) where D < D1.
faster causes spd = S + 2 if spd = S where S + 2 =< 12.
nonexecutable faster if spd = S where S + 2 > 12.
nonexecutable faster & drive(D).
:- query maxstep :: 3; 0: pos = 0 & spd = 0.
"""


def test_the_planner_counts_the_same_histories_with_and_without_order_variables(monkeypatch):
    ordered = Domain.from_text(CAR)
    histories = ordered.solve(solutions=0).histories
    size = len(ordered.templates[3].clauses)
    monkeypatch.setattr(intervals, "MIN_ROWS", 10**9)
    plain = Domain.from_text(CAR)
    want = plain.solve(solutions=0).histories
    assert len(histories) == len(want) > 1
    assert {h.key() for h in histories} == {h.key() for h in want}
    assert size < len(plain.templates[3].clauses)


def test_order_variables_are_functions_of_the_atoms():
    """Whichever value holds, or none, ``at_least[k]`` is true exactly when it is the k-th or
    a later one: the definition alone fixes it (several values at once it refuses)."""
    clauses: list = []
    lits = [1, 2, 3, 4, 5]
    at_least = intervals._order(lits, clauses.append, iter(range(6, 20)).__next__)
    clauses += [[-a, -b] for a in lits for b in lits if a < b]
    with Solver(name="glucose4", bootstrap_with=clauses) as s:
        models = list(s.enum_models())
    assert len(models) == len(lits) + 1
    for m in models:
        true = {x for x in m if x > 0}
        for k in range(1, len(lits)):
            assert (at_least[k] in true) == any(x in true for x in lits[k:])
