"""The decision-diagram encoding of table-shaped completions (cplus.sat.tables): for random
tables its models are exactly the table's rows, one model per row (node variables are
functions of the atoms), and the planner's answers do not change when it is used."""
from __future__ import annotations

import itertools

from hypothesis import given, settings
from hypothesis import strategies as st
from pysat.solvers import Solver

from cplus import Domain
from cplus.sat import templates
from cplus.sat.cnf import ClauseBuilder
from cplus.sat.tables import encode_table


@st.composite
def tables(draw):
    n = draw(st.integers(1, 3))
    domains = [tuple(range(draw(st.integers(1, 4)))) for _ in range(n)]
    values = draw(st.integers(1, 4))

    def cube():
        keys = draw(st.lists(st.integers(0, n - 1), unique=True, max_size=n))
        return {k: draw(st.sampled_from(domains[k])) for k in keys}
    strong = [(draw(st.integers(0, values - 1)), cube()) for _ in range(draw(st.integers(1, 6)))]
    weak = [(draw(st.integers(0, values - 1)), cube()) for _ in range(draw(st.integers(0, 2)))]
    return domains, values, strong, weak


def expected_rows(domains, values, strong, weak):
    """Each full assignment with the value the rules give it (strong first, then weak)."""
    rows = set()
    for full in itertools.product(*domains):
        def fires(cube, full=full):
            return all(full[k] == w for k, w in cube.items())
        hs = {h for h, c in strong if fires(c)}
        if not hs:
            hs = {h for h, c in weak if fires(c)}
            if len(hs) > 1:
                return None          # a choice: not a table
        if len(hs) == 1:
            rows.add((full, hs.pop()))
    return rows


@settings(max_examples=150)
@given(tables(), st.booleans())
def test_models_are_the_rows_of_the_table(spec, large):
    """Both builders: lists (small tables) and numpy arrays (large ones)."""
    from cplus.sat import tables as module
    domains, values, strong, weak = spec
    old = module._SMALL, module._COLD
    if large:
        module._SMALL, module._COLD = 0, 0
    try:
        check_table(domains, values, strong, weak)
    finally:
        module._SMALL, module._COLD = old


def check_table(domains, values, strong, weak):
    top = [0]

    def new_var():
        top[0] += 1
        return top[0]
    value_lits = [{w: new_var() for w in d} for d in domains]
    head_lits = [new_var() for _ in range(values)]
    base = top[0]
    cb = ClauseBuilder(new_var)
    for lits in value_lits:
        cb.exactly_one(list(lits.values()))
    cb.exactly_one(head_lits)
    ok = encode_table(domains, value_lits, head_lits, [(h, tuple(c.items())) for h, c in strong],
                      [(h, tuple(c.items())) for h, c in weak],
                      lambda c: cb.add_clause(c) if c else cb.add(False), new_var, cb.at_most_one)
    want = expected_rows(domains, values, strong, weak)
    if not ok:   # refused only when weak rules leave a choice somewhere
        assert any(h1 != h2 and all(c1.get(k, c2.get(k)) == c2.get(k, c1.get(k)) for k in range(len(domains)))
                   for (h1, c1), (h2, c2) in itertools.combinations(weak, 2))
        return
    got = []
    with Solver(name="glucose4", bootstrap_with=cb.clauses) as s:
        for model in s.enum_models():
            true = {v for v in model if v > 0}
            full = tuple(next(w for w, lit in value_lits[k].items() if lit in true) for k in range(len(domains)))
            got.append((full, next(h for h, lit in enumerate(head_lits) if lit in true)))
            assert top[0] >= base
    assert len(got) == len(set(got)), "node variables must be functions of the atoms"
    assert set(got) == want


SPACECRAFT_LIKE = """
:- sorts integer.
:- objects -4..4 :: integer.
:- variables V, V1, P :: integer.
:- constants pos :: simpleFluent(integer); vel :: inertialFluent(integer); push, pull :: exogenousAction.
push causes vel = V + 2 if vel = V where V < 3.
pull causes vel = V - 2 if vel = V where V > -3.
caused pos = P + ((V + V1) // 2) if vel = V1 after vel = V & pos = P
   where (V + V1) mod 2 == 0 & P + ((V + V1) // 2) >= -4 & P + ((V + V1) // 2) =< 4.
:- query maxstep :: 3; 0: pos = 0 & vel = 0.
"""


def test_the_planner_counts_the_same_histories_with_and_without_tables(monkeypatch):
    with_tables = Domain.from_text(SPACECRAFT_LIKE).solve(solutions=0)
    monkeypatch.setattr(templates, "_table_completion", lambda *a: False)
    without = Domain.from_text(SPACECRAFT_LIKE).solve(solutions=0)
    assert len(with_tables.histories) == len(without.histories) > 1
    assert {h.key() for h in with_tables.histories} == {h.key() for h in without.histories}


@st.composite
def _tables(draw):
    shape = tuple(draw(st.lists(st.integers(1, 4), min_size=1, max_size=4)))
    domains = [tuple(f"v{i}" for i in range(s)) for s in shape]

    def cube():
        ks = draw(st.lists(st.integers(0, len(shape) - 1), unique=True, max_size=len(shape)))
        return tuple((k, domains[k][draw(st.integers(0, shape[k] - 1))]) for k in sorted(ks))
    heads = draw(st.integers(1, 3))
    strong = [(draw(st.integers(0, heads - 1)), cube()) for _ in range(draw(st.integers(0, 6)))]
    weak = [(draw(st.integers(0, heads - 1)), cube()) for _ in range(draw(st.integers(0, 3)))]
    return shape, domains, strong, weak


@settings(max_examples=300)
@given(_tables())
def test_the_list_and_the_array_builders_make_the_same_table(t):
    """Small tables are built with lists, large ones with numpy: the same cells, order and
    levels for any cubes (or the same refusal)."""
    from cplus.sat.tables import _build_large, _build_small
    shape, domains, strong, weak = t
    index = [{w: i for i, w in enumerate(d)} for d in domains]
    small = _build_small(shape, index, [(h, dict(c)) for h, c in strong], [(h, dict(c)) for h, c in weak])
    large = _build_large(shape, index, strong, weak)
    if small is None or large is None:
        assert small is None and large is None
        return
    assert [list(map(int, x)) if not isinstance(x, int) else x for x in small[0]] == list(map(int, large[0]))
    assert list(small[1]) == list(large[1])
    # the node ids of a level: the same partition of its rows, numbered in the same order
    assert [list(map(int, lv)) for lv in small[2]] == [list(map(int, lv)) for lv in large[2]]


PHYSICS = """
:- sorts integer; speed; axis.
:- objects -{n}..{n} :: integer; -{v}..{v} :: speed; x, y :: axis.
:- variables Ax :: axis; V, V1 :: speed; P :: integer.
:- constants pos(axis) :: simpleFluent(integer); vel(axis) :: inertialFluent(speed);
  push(axis), pull(axis) :: exogenousAction.
push(Ax) causes vel(Ax) = V + {step} if vel(Ax) = V where V + {step} =< {v}.
pull(Ax) causes vel(Ax) = V - {step} if vel(Ax) = V where V - {step} >= -{v}.
caused pos(Ax) = {head} if vel(Ax) = V1 after vel(Ax) = V & pos(Ax) = P
   where {where}.
:- query maxstep :: 2; 0: pos(x) = 0 & vel(x) = 0 & pos(y) = 1 & vel(y) = 0.
"""


@settings(max_examples=25, deadline=None)
@given(st.integers(2, 7), st.integers(1, 4), st.integers(1, 3),
       st.sampled_from(["P + ((V + V1) // 2)", "P + V1", "P + V - V1", "(P + V * V1) mod 5", "abs(P) - V1"]),
       st.sampled_from(["(V + V1) mod 2 == 0", "V =< V1", "P \\= V", "true"]))
def test_full_rows_from_arrays_write_the_clauses_the_list_path_writes(n, v, step, head, where):
    """A physics law's rules reach the table builder as arrays (``_full_rows_completion``)
    when there are many of them: the templates, clause for clause, are the list path's."""
    import numpy  # noqa: F401  (the array path runs once numpy is loaded)

    from cplus.sat import tables as module
    bound = f"{head} >= -{n} & {head} =< {n}"
    text = PHYSICS.format(n=n, v=v, step=step, head=head, where=bound if where == "true" else f"{where} & {bound}")
    old = templates.FULL_ROWS_FROM, templates.TABLE_SMALL, module._SMALL

    def build(full_rows: bool):
        templates.FULL_ROWS_FROM = 1 if full_rows else 10**9
        domain = Domain.from_text(text)
        theory = domain.theory_for(domain.query("0"))
        return [(t.clauses, t.top) for t in templates.build_templates(theory)[1:]]
    try:
        templates.TABLE_SMALL = module._SMALL = 0     # both paths build with numpy, whatever the size
        assert build(True) == build(False)
    finally:
        templates.FULL_ROWS_FROM, templates.TABLE_SMALL, module._SMALL = old


def test_the_full_rows_path_is_taken_for_a_physics_law(monkeypatch):
    """The test above compares something: with a low threshold the array path writes the tables."""
    import numpy  # noqa: F401
    taken = []
    real = templates._full_rows_completion
    monkeypatch.setattr(templates, "_full_rows_completion", lambda *a: taken.append(real(*a)) or taken[-1])
    monkeypatch.setattr(templates, "FULL_ROWS_FROM", 1)
    monkeypatch.setattr(templates, "TABLE_SMALL", 0)
    text = PHYSICS.format(n=4, v=2, step=1, head="P + V1", where="P + V1 >= -4 & P + V1 =< 4")
    domain = Domain.from_text(text)
    result = domain.solve(solutions=0)
    assert True in taken
    monkeypatch.setattr(templates, "FULL_ROWS_FROM", 10**9)
    assert {h.key() for h in Domain.from_text(text).solve(solutions=0).histories} == {h.key() for h in result.histories}
