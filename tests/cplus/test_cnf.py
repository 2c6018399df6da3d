"""The clause builder (cplus.sat.cnf) on tiny formulas, checked against their truth tables:
every defined variable is a function of the atoms (so the models of the clauses are the
formula's models, one each: what model counting relies on), completion is the literal
completion of the rules, and unit propagation keeps the models it was given."""
from __future__ import annotations

import contextlib
import itertools

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus.ground.pf import mk_and, mk_or
from cplus.sat import cnf
from cplus.sat.cnf import CONFLICT, ClauseBuilder, compact, simplify_units

ATOMS = 4


def holds(f, a: dict[int, bool]) -> bool:
    if f is True or f is False:
        return f
    if type(f) is int:
        return a[abs(f)] == (f > 0)
    op, items = f
    return all(holds(g, a) for g in items) if op == "&" else any(holds(g, a) for g in items)


def satisfied(clauses, a: dict[int, bool]) -> bool:
    return all(any(a[abs(x)] == (x > 0) for x in c) for c in clauses)


def builder(atoms: int = ATOMS):
    top = [atoms]

    def new_var():
        top[0] += 1
        return top[0]
    return ClauseBuilder(new_var), top


def extensions(clauses, atoms: int, top: int):
    """For each assignment of the atoms 1..atoms: the assignments of all variables 1..top that
    extend it and satisfy the clauses."""
    out = {}
    for bits in itertools.product((False, True), repeat=atoms):
        base = dict(enumerate(bits, start=1))
        exts = []
        for aux in itertools.product((False, True), repeat=top - atoms):
            a = {**base, **dict(enumerate(aux, start=atoms + 1))}
            if satisfied(clauses, a):
                exts.append(a)
        out[bits] = exts
    return out


literals = st.integers(1, ATOMS).flatmap(lambda v: st.sampled_from([v, -v]))
formulas = st.recursive(
    st.one_of(literals, st.booleans()),
    lambda inner: st.tuples(st.sampled_from([mk_and, mk_or]), st.lists(inner, min_size=2, max_size=3)).map(
        lambda t: t[0](t[1])),   # as the grounder builds them: flat, without True/False inside
    max_leaves=6)


@settings(max_examples=60, deadline=None)
@given(formulas)
def test_a_defined_literal_is_the_formula_and_a_function_of_the_atoms(f):
    cb, top = builder()
    v = cb.lit(f)
    assert cb.lit(f) == v                       # defined once
    for bits, exts in extensions(cb.clauses, ATOMS, top[0]).items():
        assert len(exts) == 1, (f, bits)
        assert (exts[0][abs(v)] == (v > 0)) == holds(f, exts[0])


@settings(max_examples=60, deadline=None)
@given(formulas, st.sampled_from([0, 1, -2]))
def test_an_asserted_formula_has_its_models_and_no_others(f, guard):
    cb, top = builder()
    cb.add(f, guard)
    for bits, exts in extensions(cb.clauses, ATOMS, top[0]).items():
        a = dict(enumerate(bits, start=1))
        want = holds(f, a) or (guard != 0 and not holds(guard, a))
        assert len(exts) == (1 if want else 0), (f, guard, bits, cb.clauses)


def test_a_negated_definition_is_shared():
    cb, _ = builder()
    v = cb.lit(("&", (1, -2)))
    assert cb.lit(("|", (-1, 2))) == -v
    w = cb.lit(("|", (("&", (1, 2)), 3)))
    assert cb.lit(("&", (("|", (-1, -2)), -3))) == -w
    assert cb.lit(True) == -cb.lit(False)
    assert cb.lit(3) == 3


def test_an_or_with_one_conjunction_is_distributed_without_new_variables():
    cb, top = builder()
    cb.add(("|", (-1, ("&", (2, 3, -4)))))
    assert {frozenset(c) for c in cb.clauses} == {frozenset(c) for c in [[-1, -4], [-1, 2], [-1, 3]]}
    assert top[0] == ATOMS


clause_items = st.one_of(literals, st.lists(literals, min_size=2, max_size=3).map(lambda xs: ("|", tuple(xs))),
                         st.lists(literals, min_size=2, max_size=2).map(lambda xs: ("&", tuple(xs))))


@settings(max_examples=200, deadline=None)
@given(st.lists(literals, max_size=3), st.lists(clause_items, min_size=2, max_size=4), st.sampled_from([0, 1, -2]))
def test_distributing_over_a_conjunction_writes_what_the_general_path_writes(rest, items, guard):
    """``rest | (g1 & g2 & ...)`` with literal ``rest``: the clauses, in order, are those of
    asserting each ``mk_or(rest + (g,))`` on its own (repeated and complementary literals,
    items that are clauses or conjunctions, a guard)."""
    fast, _ = builder()
    fast._distribute(tuple(rest), tuple(items), guard)
    general, _ = builder()
    for g in items:
        general.add(mk_or(tuple(rest) + (g,)), guard)
    assert fast.clauses == general.clauses


def test_false_is_one_variable_forced_false():
    cb, top = builder()
    cb.add(False)
    cb.add(False, 2)
    assert cb.clauses == [[-5], [5], [-2]]          # with a guard: the guard is false
    assert top[0] == 5


def reference_completion(head: int, bodies, free: bool, a: dict[int, bool]) -> bool:
    """Literal completion: each body b -> head, and head -> some body; a body with head as a
    conjunct gives only its rest in the second direction, and none in the first."""
    alternatives = []
    for b in bodies:
        if b is False:
            continue
        if type(b) is int and b == head:     # (True == 1: compare ints only)
            rest = True
        elif type(b) is tuple and b[0] == "&" and head in b[1]:
            rest = mk_and(g for g in b[1] if g != head)
        else:
            if holds(b, a) and not holds(head, a):
                return False
            alternatives.append(b)
            continue
        alternatives.append(rest)
    if free:
        return True
    return not holds(head, a) or any(holds(alt, a) for alt in alternatives)


bodies_of = st.lists(st.one_of(formulas, st.just(1), st.just(-1),
                               st.lists(st.sampled_from([1, -1, 2, -2, 3, -3, 4]), min_size=2, max_size=3,
                                        unique_by=abs).map(lambda ls: mk_and(ls))),
                     max_size=3)


@settings(max_examples=100, deadline=None)
@given(bodies_of, st.booleans(), st.sampled_from([1, 2, -2]))
def test_completion_is_the_literal_completion(bodies, free, head):
    cb, top = builder()
    cb.complete(head, bodies, free)
    for bits, exts in extensions(cb.clauses, ATOMS, top[0]).items():
        a = dict(enumerate(bits, start=1))
        assert len(exts) == (1 if reference_completion(head, bodies, free, a) else 0), (bodies, free, bits)


@pytest.mark.parametrize("bodies, clauses", [
    ([2], [[-2, 1], [-1, 2]]),
    ([-1], [[1], [-1]]),                      # caused h if -h: h <-> -h, no model
    ([1], []),
    ([1, 2], [[-2, 1]]),
    ([False], [[-1]]),
    ([True], [[1]]),                          # caused h: h (True is not the literal 1)
    ([], [[-1]]),
    ([("&", (2, 3))], [[-2, -3, 1], [-1, 5], [-5, 2], [-5, 3], [5, -2, -3]]),
    ([("&", (-1, 2))], [[1, -2], [-1, 5], [-5, -1], [-5, 2], [5, 1, -2]]),
    ([("&", (1, 2))], [[-1, 2]]),
    ([("&", (1, 2)), 3], [[-3, 1], [-1, 2, 3]]),
    ([("&", (1, 2, 3))], [[-1, 5], [-5, 2], [-5, 3], [5, -2, -3]]),
    ([("|", (2, 3))], [[-2, 1], [-3, 1], [-1, 2, 3]]),
])
def test_completion_clauses_of_the_common_shapes(bodies, clauses):
    """The shapes the grounder gives most (a literal, a conjunction of literals) take the
    short forms; a defined variable (5, the first new one) only where a formula needs it."""
    cb, _ = builder()
    cb.complete(1, bodies)
    assert {frozenset(c) for c in cb.clauses} == {frozenset(c) for c in clauses}
    assert len(cb.clauses) == len(clauses)


@pytest.mark.parametrize("n", [0, 1, 2, 3, 5, 24, 25, 26, 30])
def test_at_most_one_and_exactly_one(n):
    from pysat.solvers import Solver
    for exact in (False, True):
        cb, top = builder(n)
        lits = list(range(1, n + 1))
        (cb.exactly_one if exact else cb.at_most_one)(lits)
        models = []
        with Solver(name="g3", bootstrap_with=cb.clauses + [[x, -x] for x in range(1, top[0] + 1)]) as s:
            while s.solve() and len(models) <= n + 2:
                m = s.get_model() or []
                models.append(frozenset(x for x in m if 0 < x <= n))
                if not m:
                    break
                s.add_clause([-x for x in m])
            unsat_at_once = not models
        want = {frozenset([x]) for x in lits} | (set() if exact else {frozenset()})
        assert set(models) == want and len(models) == len(want), (n, exact)   # the ladder is a function too
        if exact and n == 0:
            assert unsat_at_once


def test_at_most_one_is_pairwise_up_to_24_literals():
    for n, clauses, new in [(24, 276, 0), (25, 24 + 3 * 23, 23)]:
        cb, top = builder(n)
        cb.at_most_one(list(range(1, n + 1)))
        assert (len(cb.clauses), top[0] - n) == (clauses, new)
        if new == 0:
            assert all(len(c) == 2 for c in cb.clauses)


def test_at_most_one_defines_formulas_it_is_given():
    cb, top = builder(3)
    cb.at_most_one([("&", (1, 2)), 3])
    for bits, exts in extensions(cb.clauses, 3, top[0]).items():
        a = dict(enumerate(bits, start=1))
        assert len(exts) == (0 if a[1] and a[2] and a[3] else 1)


# --------------------------------------------------------------------------- unit propagation

VARS = 6
clause_sets = st.lists(st.lists(st.integers(1, VARS).flatmap(lambda v: st.sampled_from([v, -v])),
                                min_size=1, max_size=3, unique_by=abs), max_size=12)


def models(clauses, n: int = VARS, keep: int | None = None) -> set:
    keep = n if keep is None else keep
    return {bits[:keep] for bits in itertools.product((False, True), repeat=n)
            if satisfied(clauses, dict(enumerate(bits, start=1)))}


@contextlib.contextmanager
def propagating(engine: str):
    """Unit propagation in Python (small clause sets) or with numpy (large ones), whatever the size."""
    old = cnf._NUMPY_FROM, cnf._NUMPY_COLD
    if engine == "numpy":
        cnf._NUMPY_FROM = cnf._NUMPY_COLD = 0
    else:
        cnf._NUMPY_FROM = cnf._NUMPY_COLD = 10**9
    try:
        yield
    finally:
        cnf._NUMPY_FROM, cnf._NUMPY_COLD = old


ENGINES = pytest.mark.parametrize("engine", ["python", "numpy"])


@ENGINES
@settings(max_examples=60, deadline=None)
@given(clause_sets, st.integers(2, VARS))
def test_unit_propagation_keeps_the_models(engine, clauses, keep):
    with propagating(engine):
        out = simplify_units([list(c) for c in clauses])
        if out is CONFLICT:
            assert not models(clauses)
        else:
            assert models(out) == models(clauses)
            units = {c[0] for c in out if len(c) == 1}
            assert all(len(c) == 1 or not any(abs(x) in {abs(u) for u in units} for x in c) for c in out)
        projected = simplify_units([list(c) for c in clauses], keep)
        if projected is CONFLICT:
            assert not models(clauses)
        else:
            assert models(projected, keep=keep) == models(clauses, keep=keep)
            assert all(abs(c[0]) <= keep for c in projected if len(c) == 1)


@ENGINES
@settings(max_examples=60, deadline=None)
@given(clause_sets, st.integers(2, VARS))
def test_compact_keeps_the_models_and_numbers_the_rest_densely(engine, clauses, base):
    with propagating(engine):
        out, top = compact([list(c) for c in clauses], base, VARS)
        if out is CONFLICT:
            assert not models(clauses)
            return
        used = {abs(x) for c in out for x in c if abs(x) > base}
        if any(len(c) == 1 for c in clauses):
            assert used == set(range(base + 1, top + 1))
        else:                      # nothing to propagate: as given
            assert (out, top) == (clauses, VARS)
        assert models(out, n=max(top, base), keep=base) == models(clauses, keep=base)


@ENGINES
def test_propagation_examples(engine):
    with propagating(engine):
        assert simplify_units([[1, 2], [-1, 3]]) == [[1, 2], [-1, 3]]            # no unit: as given
        assert sorted(simplify_units([[1], [-1, 2], [-2, 3, 4], [5, 6]])) == [[1], [2], [3, 4], [5, 6]]
        assert simplify_units([[1], [-1]]) is CONFLICT
        assert simplify_units([[1], [-1, 2], [-2]]) is CONFLICT
        assert simplify_units([[1], []]) is CONFLICT
        assert sorted(simplify_units([[1], [-1, 5], [5, 2, 3]], keep=4)) == [[1]]
        assert compact([[1, 2]], 1, 2) == ([[1, 2]], 2)
        assert compact([[1], [-1, 2, 6], [2, 5]], 2, 6) == ([[1], [2, 4], [2, 3]], 4) or \
            sorted(compact([[1], [-1, 2, 6], [2, 5]], 2, 6)[0]) == [[1], [2, 3], [2, 4]]
        assert compact([[3], [-3]], 2, 3) == (CONFLICT, 3)
        assert compact([[1], [-1, 2, 3], [1, 4]], 1, 4) == ([[1], [2, 3]], 3) or \
            sorted(compact([[1], [-1, 2, 3], [1, 4]], 1, 4)[0]) == [[1], [2, 3]]


def test_numpy_propagates_the_large_clause_sets(monkeypatch):
    """From _NUMPY_FROM clauses on (numpy loaded, or from _NUMPY_COLD on), and only then."""
    used = []
    python, vector = cnf._simplify_python, cnf._simplify_numpy
    monkeypatch.setattr(cnf, "_simplify_python", lambda *a, **k: used.append("python") or python(*a, **k))
    monkeypatch.setattr(cnf, "_simplify_numpy", lambda *a, **k: used.append("numpy") or vector(*a, **k))
    monkeypatch.setattr(cnf, "_NUMPY_FROM", 4)
    monkeypatch.setattr(cnf, "_NUMPY_COLD", 4)
    three, four, five = [[1], [-1, 2], [2, 3]], [[1], [-1, 2], [2, 3], [3, 4]], [[1], [-1, 2], [2, 3], [3, 4], [4, 5]]
    for f in (simplify_units, lambda c: compact(c, 5, 5)):
        used.clear()
        f(three)
        f(four)
        f(five)
        assert used == ["python", "numpy", "numpy"]


def test_a_long_chain_of_units_is_followed_to_its_end():
    chain = [[1]] + [[-i, i + 1] for i in range(1, 150)]
    assert sorted(simplify_units(chain)) == [[i] for i in range(1, 151)]


def test_mk_helpers_used_by_the_builder_agree_with_truth_tables():
    for f in [mk_or((1, ("&", (2, 3)))), mk_and((1, 2, 2)), mk_or((1, -1))]:
        cb, top = builder()
        cb.add(f)
        for bits, exts in extensions(cb.clauses, ATOMS, top[0]).items():
            assert len(exts) == (1 if holds(f, dict(enumerate(bits, start=1))) else 0)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(literals, st.booleans(), st.tuples(st.just("|"), st.tuples(literals, literals))), max_size=5),
       st.booleans())
def test_the_builders_fast_paths_build_what_the_general_one_builds(items, as_tuple):
    """mk_and and mk_or of two literals, and mk_and of a list of literals (a rule body), are
    what the general flattening gives: the same formula, items in the same order."""
    from cplus.ground.pf import _nary
    given_items = tuple(items) if as_tuple else list(items)
    assert mk_and(given_items) == _nary("&", True, list(items))
    assert mk_or(given_items) == _nary("|", False, list(items))
