"""When cplus.sat.intervals writes a constant's constraints through its order: exactly when
its clauses (four a value, one a run) are at most GAIN of the ones they replace, on MIN_ROWS
constraints or more; which constant is taken out of a body (the one with the most values);
and what it leaves alone."""
from __future__ import annotations

import pytest

from cplus.sat import intervals

N = 7                                   # the constant's values 0..6, literals 1..7; rests 101, 102, ...


def factor(lengths: list[int], others: int = 1):
    """Constraints ``rest_i & c=v`` for v in 0..lengths[i]-1 (one run each): (bodies left,
    clauses written, variables made)."""
    bodies = [tuple(100 + 10 * i + k for k in range(others)) + (1 + v,) for i, n in enumerate(lengths)
              for v in range(n)]
    written: list[list[int]] = []
    top = [1000]

    def new_var() -> int:
        top[0] += 1
        return top[0]
    rest = intervals.factor_intervals(bodies, lambda x: ("c", x - 1) if 1 <= x <= N else None,
                                      lambda key: {v: v + 1 for v in range(N)}, written.append, new_var)
    return rest, written, top[0] - 1000


@pytest.fixture
def few_rows(monkeypatch):
    monkeypatch.setattr(intervals, "MIN_ROWS", 0)


def test_written_through_the_order_exactly_when_it_pays(few_rows):
    # 12 runs and 7 values: 4 * 7 + 12 = 40 clauses at most, against 80 rows: 40 <= 0.5 * 80
    rest, written, made = factor([7] * 8 + [6] * 4)
    assert rest == [] and made == N - 1
    assert len(written) == 4 * (N - 1) - 1 + 12         # the order's clauses (23), one a run
    # 79 rows: 40 > 39.5, left as they are
    rest, written, made = factor([7] * 7 + [6] * 5)
    assert len(rest) == 79 and written == [] and made == 0


def test_only_from_min_rows_on(monkeypatch):
    monkeypatch.setattr(intervals, "GAIN", 1.0)
    lengths = [7] * 28 + [4]                       # 200 rows, 29 runs: 28 + 29 <= 200
    assert factor(lengths)[0] == [] and intervals.MIN_ROWS == 200
    rest, written, _ = factor(lengths[:-1] + [3])  # 199 rows
    assert len(rest) == 199 and written == []


def test_the_constant_with_the_most_values_is_taken_out(few_rows):
    """Bodies over a 3-valued constant (literals 201..203) and the 7-valued one: the order is
    the 7-valued one's (6 variables), not the other's (2)."""
    bodies = [(201 + a, 1 + v) for a in range(3) for v in range(N)]
    written: list[list[int]] = []
    made = []

    def new_var() -> int:
        made.append(1)
        return 1000 + len(made)

    def atom_of(x):
        return ("c", x - 1) if 1 <= x <= N else (("a", x - 201) if 201 <= x <= 203 else None)

    def values_of(key):
        return {v: v + 1 for v in range(N)} if key == "c" else {v: 201 + v for v in range(3)}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(intervals, "GAIN", 10.0)
        rest = intervals.factor_intervals(bodies, atom_of, values_of, written.append, new_var)
    assert rest == [] and len(made) == N - 1
    assert sorted(c for c in written if len(c) == 1) == [[-203], [-202], [-201]]    # each a forbids every c


def test_a_one_literal_constraint_stays_a_unit(few_rows, monkeypatch):
    monkeypatch.setattr(intervals, "GAIN", 10.0)
    bodies = [(1 + v,) for v in range(N)] + [(101, 1 + v) for v in range(N)]
    written: list[list[int]] = []
    rest = intervals.factor_intervals(bodies, lambda x: ("c", x - 1) if 1 <= x <= N else None,
                                      lambda key: {v: v + 1 for v in range(N)}, written.append, lambda: 1000)
    assert rest == [(1 + v,) for v in range(N)]
