"""Constraints over four constants whose forbidden tuples are a product of pair classes.

A law such as the payload's length bound

    caused false if xpay(pl1)=X1 & xpay(pl2)=X2 & ypay(pl1)=Y1 & ypay(pl2)=Y2
      where (X2-X1)*(X2-X1)+(Y2-Y1)*(Y2-Y1) < 23 ++ ...

grounds to one four-literal clause per forbidden tuple, although whether a tuple is forbidden
depends only on ``X2-X1`` and ``Y2-Y1``.  Split the four constants into two pairs, *left* and
*right*; call two left assignments alike when they are forbidden with the same right
assignments, and two right assignments alike when they are forbidden with the same classes
of left ones.  Then the forbidden tuples are exactly the pairs (left, right) whose classes
are forbidden together, so one variable per class, defined as the disjunction of its
assignments, turns the family into

* ``a & b -> p`` for each left assignment ``(a, b)`` of class ``p`` (and the same on the right),
* ``p -> a1 | a2 | ...`` and ``p & a -> b1 | b2 | ...`` (``p`` holds only through a member),
* ``-p | -q`` for each forbidden pair of classes.

Every class variable is a function of the atoms whenever each constant has at most one value
(in every model each has exactly one), so the models and their count do not move.

On the payload task the family (the length law and the payload's obstacles, over the same
four coordinates) is 12,829 clauses a step on the shipped scene and becomes 1,846; the
raised wall's proof of no safe plan got 27% faster (median of 9 solver paths), the island
and the shipped task did not move beyond the spread.  The corpus has no family it applies to.
It is used only where it pays (:data:`MIN_ROWS`, :data:`GAIN`); other constraints stay one
clause each.
"""
from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence

__all__ = ["factor_products", "MIN_ROWS", "GAIN"]

MIN_ROWS = 200      # a family smaller than this is left as it is
GAIN = 0.3          # the classes' clauses must be at most this share of the family's
_SPLITS = ((0, 1, 2, 3), (0, 2, 1, 3), (0, 3, 1, 2))


def factor_products(bodies: Sequence[tuple[int, ...]], key_of: Callable[[int], Hashable | None],
                    add_clause: Callable[[list[int]], None], new_var: Callable[[], int]
                    ) -> list[tuple[int, ...]]:
    """Write the families of four-atom constraints that factor through pair classes, and
    return the bodies left to write one clause each.

    ``bodies`` are conjunctions of literals, each forbidden; ``key_of(lit)`` is the constant
    (with its step) whose value a positive literal states, or None (a negated value, an
    auxiliary variable): only bodies of four values of four distinct constants take part.
    """
    families: dict[tuple, list[tuple[int, ...]]] = {}
    rest: list[tuple[int, ...]] = []
    orders: dict[tuple, tuple[tuple, tuple[int, ...]] | None] = {}   # keys as met -> (family, order)
    for body in bodies:
        if len(body) == 4 and min(body) > 0:
            keys = tuple(map(key_of, body))
            if keys in orders:
                known = orders[keys]
            else:
                known = orders[keys] = _family(keys)
            if known is not None:
                sig, (i, j, k, m) = known
                families.setdefault(sig, []).append((body[i], body[j], body[k], body[m]))
                continue
        rest.append(body)
    for rows in families.values():
        found = _classes(rows) if len(rows) >= MIN_ROWS else None
        if found is None:
            rest.extend(rows)
            continue
        left, right, pairs = found
        lv, rv = _define(left, add_clause, new_var), _define(right, add_clause, new_var)
        for c, d in pairs:
            add_clause([-lv[c], -rv[d]])
    return rest


def _family(keys: tuple) -> tuple[tuple, tuple[int, ...]] | None:
    """The family of a body whose literals state values of these constants (sorted), and the
    order that lists its literals as the family does; None unless four distinct constants."""
    if None in keys or len(set(keys)) != 4:
        return None
    order = tuple(sorted(range(4), key=keys.__getitem__))
    return tuple(keys[i] for i in order), order


def _classes(rows: list[tuple[int, ...]]) -> tuple[list, list, set] | None:
    """The first split that pays: (left classes, right classes, forbidden class pairs), each
    class a list of assignments (pairs of literals); None when none does.  The family's
    constants are sorted by id, that is by declaration, so the first split pairs instances
    of one declaration (``xpay(pl1)`` with ``xpay(pl2)``), where a law over differences
    factors; trying the others only when it does not pay keeps the cost to one pass."""
    for i, j, k, m in _SPLITS:
        with_left: dict[tuple[int, int], set[tuple[int, int]]] = {}
        for r in rows:
            with_left.setdefault((r[i], r[j]), set()).add((r[k], r[m]))
        lcls: dict[frozenset, list] = {}
        for a, forbidden in with_left.items():
            lcls.setdefault(frozenset(forbidden), []).append(a)
        if len(lcls) == len(with_left):   # no two alike: nothing to share
            continue
        lid = {a: n for n, members in enumerate(lcls.values()) for a in members}
        with_right: dict[tuple[int, int], set[int]] = {}
        for a, forbidden in with_left.items():
            for b in forbidden:
                with_right.setdefault(b, set()).add(lid[a])
        rcls: dict[frozenset, list] = {}
        for b, cs in with_right.items():
            rcls.setdefault(frozenset(cs), []).append(b)
        pairs = {(c, d) for d, cs in enumerate(rcls) for c in cs}
        cost = len(pairs) + _definition_size(lcls.values()) + _definition_size(rcls.values())
        if cost <= GAIN * len(rows):
            return list(lcls.values()), list(rcls.values()), pairs
    return None


def _definition_size(classes) -> int:
    """Clauses of :func:`_define` for these classes."""
    return sum(len(members) + 1 + len({a for a, _ in members}) for members in classes)


def _define(classes: list[list[tuple[int, int]]], add_clause: Callable[[list[int]], None],
            new_var: Callable[[], int]) -> list[int]:
    """A variable per class, true exactly when one of its assignments holds."""
    out = []
    for members in classes:
        p = new_var()
        out.append(p)
        seconds: dict[int, list[int]] = {}
        for a, b in members:
            add_clause([-a, -b, p])
            seconds.setdefault(a, []).append(b)
        add_clause([-p, *seconds])
        for a, bs in seconds.items():
            add_clause([-p, -a, *bs])
    return out
