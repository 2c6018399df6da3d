"""Constraint families written through pair classes (cplus.sat.products): for random families
the models over the atoms are those of one clause per forbidden tuple, one model each (the
class variables are functions of the atoms); a length law shrinks; the planner's answers do
not change when it is used."""
from __future__ import annotations

from itertools import product

from hypothesis import given, settings
from hypothesis import strategies as st
from pysat.solvers import Solver
from test_semantics import forced

from cplus import Domain
from cplus.sat import products
from cplus.sat.cnf import ClauseBuilder

SIZES = (3, 2, 3, 3)


def models(forbidden: list[tuple[int, ...]], factor: bool, sizes=SIZES, extra: list[tuple[int, ...]] = ()
           ) -> tuple[list[frozenset], int]:
    """The models over the atoms of four exactly-one constants with ``forbidden`` value
    tuples (and ``extra`` ones over the first three only), and the number of clauses."""
    top = [0]

    def new_var() -> int:
        top[0] += 1
        return top[0]
    lits = [[new_var() for _ in range(n)] for n in sizes]
    atoms = top[0]
    const_of = {x: k for k, xs in enumerate(lits) for x in xs}
    cb = ClauseBuilder(new_var)
    for xs in lits:
        cb.exactly_one(xs)
    bodies = [tuple(lits[k][v] for k, v in enumerate(row)) for row in forbidden]
    bodies += [tuple(lits[k][v] for k, v in enumerate(row)) for row in extra]
    if factor:
        bodies = products.factor_products(bodies, const_of.get, cb.add_clause, new_var)
    for body in bodies:
        cb.add_clause([-x for x in body])
    with Solver(name="glucose4", bootstrap_with=cb.clauses) as s:
        found = [frozenset(x for x in m if 0 < x <= atoms) for m in s.enum_models()]
    assert len(found) == len(set(found)), "class variables must be functions of the atoms"
    return found, len(cb.clauses)


@st.composite
def families(draw):
    """Forbidden tuples: a function of two differences (as a length law), with noise."""
    cells = list(product(*(range(n) for n in SIZES)))
    if draw(st.booleans()):
        bad = draw(st.sets(st.tuples(st.integers(-2, 2), st.integers(-2, 2))))
        rows = [c for c in cells if (c[1] - c[0], c[3] - c[2]) in bad]
    else:
        rows = []
    rows = sorted(set(rows) ^ set(draw(st.lists(st.sampled_from(cells), max_size=6))))
    extra = draw(st.lists(st.tuples(*(st.integers(0, n - 1) for n in SIZES[:3])), max_size=3))
    return rows, extra


@settings(max_examples=200, deadline=None)
@given(families())
def test_factored_families_have_the_models_of_one_clause_per_tuple(spec):
    rows, extra = spec
    want, _ = models(rows, False, extra=extra)
    with forced(products):
        got, _ = models(rows, True, extra=extra)
    assert set(got) == set(want)


def test_a_length_law_shrinks_to_a_clause_per_class_pair():
    """Ends on an 8 x 8 grid, a squared length outside 8..10 forbidden: 4,096 tuples of which
    most are forbidden, written through the classes of the x pair and of the y pair."""
    n = 8
    rows = [(x1, x2, y1, y2) for x1, x2, y1, y2 in product(range(n), repeat=4)
            if not 8 <= (x2 - x1) ** 2 + (y2 - y1) ** 2 <= 10]
    want, plain = models(rows, False, sizes=(n,) * 4)
    got, size = models(rows, True, sizes=(n,) * 4)
    assert set(got) == set(want) and len(want) == n ** 4 - len(rows)
    assert size < products.GAIN * plain


def test_unrelated_tuples_are_left_as_they_are():
    """No two assignments of a pair are alike, whichever the split (a Latin square): nothing
    to share, nothing written."""
    rows = [(a, b, (a + b) % 3, (a + 2 * b) % 3) for a in range(3) for b in range(3)]
    written: list = []
    with forced(products):
        rest = products.factor_products([tuple(10 * k + v for k, v in enumerate(r)) for r in rows],
                                        lambda x: x // 10, written.append, lambda: 99)
    assert written == [] and len(rest) == len(rows)


STICK = """
:- sorts coord; end.
:- objects 0..5 :: coord; a, b :: end.
:- variables X1, X2, Y1, Y2 :: coord; E :: end.
:- constants x(end), y(end) :: inertialFluent(coord); nudge(end) :: exogenousAction.
nudge(E) causes x(E) = X2 if x(E) = X1 where X2 = X1 + 1.
nonexecutable nudge(E) if x(E) = 5.
caused false if x(a) = X1 & x(b) = X2 & y(a) = Y1 & y(b) = Y2
  where (X2-X1)*(X2-X1) + (Y2-Y1)*(Y2-Y1) < 4 ++ (X2-X1)*(X2-X1) + (Y2-Y1)*(Y2-Y1) > 5.
:- query maxstep :: 2; 0: y(a) = 0.
"""


def test_the_planner_counts_the_same_histories_with_and_without_products(monkeypatch):
    factored = Domain.from_text(STICK)
    histories = factored.solve(solutions=0).histories
    size = len(factored.templates[2].extra[0][0].clauses)
    monkeypatch.setattr(products, "MIN_ROWS", 10**9)
    plain = Domain.from_text(STICK)
    want = plain.solve(solutions=0).histories
    assert len(histories) == len(want) > 1
    assert {h.key() for h in histories} == {h.key() for h in want}
    assert size < len(plain.templates[2].extra[0][0].clauses)
