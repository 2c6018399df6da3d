"""When cplus.sat.products writes a family through pair classes: its cost estimate is the
number of clauses the classes take, and the family is written so exactly when that cost is at
most GAIN of its rows, from MIN_ROWS rows on; a body that is not four values of four
constants is left alone."""
from __future__ import annotations

from itertools import product

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus.sat import products

SIZE = 5


def length_family() -> list[tuple[int, ...]]:
    """Literal 10*k + v + 1 states value v of constant k; ends (x1, x2, y1, y2) on a 5 x 5 grid
    whose squared length is not 5."""
    return [tuple(10 * k + v + 1 for k, v in enumerate(c)) for c in product(range(SIZE), repeat=4)
            if (c[1] - c[0]) ** 2 + (c[3] - c[2]) ** 2 != 5]


def run(rows):
    written: list[list[int]] = []
    top = [1000]

    def new_var() -> int:
        top[0] += 1
        return top[0]
    rest = products.factor_products(rows, lambda x: (x - 1) // 10, written.append, new_var)
    return rest, written


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.tuples(st.integers(1, 4), st.integers(5, 8)), min_size=1, max_size=5, unique=True),
                min_size=1, max_size=4))
def test_the_definition_size_is_the_clauses_written(classes):
    written: list[list[int]] = []
    products._define(classes, written.append, iter(range(100, 200)).__next__)
    assert products._definition_size(classes) == len(written)


def test_written_exactly_when_the_classes_cost_at_most_gain_of_the_rows(monkeypatch):
    rows = length_family()
    monkeypatch.setattr(products, "GAIN", 1.0)
    left, right, pairs = products._classes(rows)
    cost = len(pairs) + products._definition_size(left) + products._definition_size(right)
    assert cost < len(rows)
    monkeypatch.setattr(products, "GAIN", cost / len(rows))
    rest, written = run(rows)
    assert rest == [] and len(written) == cost
    monkeypatch.setattr(products, "GAIN", (cost - 0.5) / len(rows))
    rest, written = run(rows)
    assert len(rest) == len(rows) and written == []


def test_only_from_min_rows_on(monkeypatch):
    rows = length_family()
    monkeypatch.setattr(products, "GAIN", 1.0)
    monkeypatch.setattr(products, "MIN_ROWS", len(rows))
    assert run(rows)[0] == []
    monkeypatch.setattr(products, "MIN_ROWS", len(rows) + 1)
    assert len(run(rows)[0]) == len(rows)


def test_the_shipped_thresholds():
    """200 rows and 0.3: the length family of a 5 x 5 grid (529 rows) pays."""
    assert (products.MIN_ROWS, products.GAIN) == (200, 0.3)
    rest, written = run(length_family())
    assert rest == [] and 0 < len(written) <= 0.3 * len(length_family())


@pytest.mark.parametrize("body", [(1, 11, 21), (1, 11, 21, 31, 41), (1, 2, 21, 31), (1, 11, 21, -31), (1, 11, 21, 0)])
def test_other_bodies_are_left_alone(body, monkeypatch):
    monkeypatch.setattr(products, "MIN_ROWS", 0)
    rest, written = run([body])
    assert rest == [body] and written == []
