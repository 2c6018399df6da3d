"""Constraints that forbid a range of an integer constant, written through its order.

A threshold law grounds to one clause per forbidden value:

    nonexecutable drive(D) if pos = P & spd = S where P + S * D > 300.

gives, for each duration ``D`` and speed ``S``, a clause ``-drive(D) | -spd=S | -pos=P`` for
every position ``P`` above ``300 - S*D``: tens of thousands of clauses a step for 300 pairs
(car-300's constraints are 5,967 clauses a step once the values its start cannot reach are
left out; written as below, 709).
For each *rest* (the constraint's other literals) the forbidden positions are a few runs of
consecutive values, and with *order variables* ``pos>=v`` a run ``lo..hi`` is one clause,
``-rest | -(pos>=lo) | (pos>=hi+1)``.  The order variables of a constant (at one step) are
defined once, four clauses a value:

* ``pos=v -> pos>=v`` and ``pos=v -> -(pos>=v+1)``,
* ``pos>=v+1 -> pos>=v``, and ``pos>=v -> pos=v | pos>=v+1`` (the last: ``-> pos=v``),

which makes each a function of the atoms whenever the constant has at most one value (in
every model it has exactly one), so the models and their count do not move.  A constant is
taken out of a body when it has the most values there; it is used only where it pays
(:data:`MIN_ROWS`, :data:`GAIN`), otherwise the constraints stay one clause each.
:mod:`cplus.sat.products` takes its families first.  Values a query's start cannot reach
(dead, false at every step) are left out of the order, so a run may step over them.

car-300 went from 0.27 to 0.24 s for the whole command (solving 0.03 to 0.01 s); the payload
arms' straight moves past obstacles (2,352 clauses a step) become 1,350.
"""
from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from itertools import chain
from typing import Any

__all__ = ["factor_intervals", "MIN_ROWS", "GAIN"]

MIN_ROWS = 200      # constraints on one constant below which nothing changes
GAIN = 0.5          # the new clauses must be at most this share of the ones they replace


def factor_intervals(bodies: Sequence[tuple[int, ...]],
                     atom_of: Callable[[int], tuple[Hashable, object] | None],
                     values_of: Callable[[Any], dict[object, int]],
                     add_clause: Callable[[list[int]], None], new_var: Callable[[], int]
                     ) -> list[tuple[int, ...]]:
    """Write the constraints that runs of values of one integer constant share, and return
    the bodies left to write otherwise.

    ``bodies`` are conjunctions of literals, each forbidden; ``atom_of(lit)`` is
    ``(constant, value)`` for a positive literal stating a constant's value, else None;
    ``values_of(constant)`` the literal of each of its values in increasing order when they
    are all integers, else nothing (the constant is never taken out).
    """
    known: dict[Hashable, dict[object, int]] = {}
    score: dict[int, int] = {}      # literal -> values of its constant when it may be taken out, else 0
    for g in set(chain.from_iterable(bodies)):
        atom = atom_of(g) if g > 0 else None
        n = 0
        if atom is not None:
            values = known.get(atom[0])
            if values is None:
                values = known[atom[0]] = values_of(atom[0])
            if len(values) > 2 and atom[1] in values:
                n = len(values)
        score[g] = n
    at = score.__getitem__
    by_key: dict[Hashable, dict[tuple[int, ...], list[object]]] = {}
    rest: list[tuple[int, ...]] = []
    for body in bodies:
        scores = tuple(map(at, body)) if len(body) > 1 else (0,)
        best = max(scores)
        if not best:
            rest.append(body)
            continue
        i = scores.index(best)      # the first of the constants with the most values
        key, value = atom_of(body[i])  # type: ignore[misc]
        by_key.setdefault(key, {}).setdefault(body[:i] + body[i + 1:], []).append(value)
    for key, groups in by_key.items():
        rows = sum(map(len, groups.values()))
        values = known[key]
        runs: dict[tuple[int, ...], list[tuple[int, int]]] = {}
        if rows >= MIN_ROWS:
            order = {v: k for k, v in enumerate(values)}
            runs = {others: _runs(sorted(order[v] for v in set(vs))) for others, vs in groups.items()}
        if not runs or 4 * len(values) + sum(map(len, runs.values())) > GAIN * rows:
            rest.extend((*others, values[v]) for others, vs in groups.items() for v in vs)
            continue
        at_least = _order(list(values.values()), add_clause, new_var)
        for others, spans in runs.items():
            for lo, hi in spans:
                clause = [-g for g in others]
                if lo > 0:
                    clause.append(-at_least[lo])
                if hi + 1 < len(at_least):
                    clause.append(at_least[hi + 1])
                add_clause(clause)
    return rest


def _runs(indices: list[int]) -> list[tuple[int, int]]:
    """Maximal runs of consecutive integers in a sorted list, as (first, last)."""
    out: list[tuple[int, int]] = []
    for k in indices:
        if out and out[-1][1] == k - 1:
            out[-1] = (out[-1][0], k)
        else:
            out.append((k, k))
    return out


def _order(lits: list[int], add_clause: Callable[[list[int]], None], new_var: Callable[[], int]) -> list[int]:
    """``at_least[k]``: a variable true exactly when the constant's value is the k-th or a later
    one, for k >= 1 (``at_least[0]``, always true, is 0: never used)."""
    at_least = [0] + [new_var() for _ in lits[1:]]
    for k in range(1, len(lits)):
        o = at_least[k]
        add_clause([-lits[k], o])
        add_clause([-lits[k - 1], -o])
        if k + 1 < len(lits):
            add_clause([-at_least[k + 1], o])
            add_clause([-o, lits[k], at_least[k + 1]])
        else:
            add_clause([-o, lits[k]])
    return at_least
