"""Propositional formulas in negation normal form, as produced by grounding.

A formula is ``True``, ``False``, a non-zero ``int`` literal (its sign is its polarity),
or a tuple ``("&", items)`` / ``("|", items)`` whose items are formulas.  The builders
flatten, drop neutral elements, remove duplicates and spot complementary literals, so that
a ground body that cannot hold becomes ``False`` as early as possible.

>>> mk_and([1, True, ("&", (2, 3))])
('&', (1, 2, 3))
>>> mk_or([1, -1])
True
>>> neg(("&", (1, -2)))
('|', (-1, 2))
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

PF = bool | int | tuple

__all__ = ["PF", "mk_and", "mk_or", "neg", "map_lits", "lits_of"]


def _nary(op: str, unit: bool, items: Iterable[PF]) -> PF:
    """``op`` ("&" with unit True, "|" with unit False): flatten, drop the unit, stop at the
    absorbing element or at complementary literals."""
    out: list = []
    seen: set = set()
    for f in items:
        if f is unit:
            continue
        if f is (not unit):
            return not unit
        sub = f[1] if type(f) is tuple and f[0] == op else (f,)
        for g in sub:
            if g in seen:
                continue
            if type(g) is int and -g in seen:
                return not unit
            seen.add(g)
            out.append(g)
    if not out:
        return unit
    if len(out) == 1:
        return out[0]
    return (op, tuple(out))


def mk_and(items: Iterable[PF]) -> PF:
    if type(items) is tuple and len(items) == 2:     # two literals: most calls, in a few steps
        a, b = items
        if type(a) is int and type(b) is int:
            return a if a == b else False if a == -b else ("&", items)
    elif type(items) is list and len(items) > 1 and tuple not in map(type, items) and bool not in map(type, items):
        seen = set(items)                            # a rule body of literals, as a law's parts give it
        if len(seen) == len(items):
            for x in items:
                if -x in seen:
                    return False
            return ("&", tuple(items))
    return _nary("&", True, items)


def mk_or(items: Iterable[PF]) -> PF:
    if type(items) is tuple and len(items) == 2:
        a, b = items
        if type(a) is int and type(b) is int:
            return a if a == b else True if a == -b else ("|", items)
    return _nary("|", False, items)


def neg(f: PF) -> PF:
    if type(f) is int:
        return -f
    if f is True:
        return False
    if f is False:
        return True
    op, items = f  # type: ignore[misc]
    return ("|" if op == "&" else "&", tuple([-g if type(g) is int else neg(g) for g in items]))


def map_lits(f: PF, fn: Callable[[int], int]) -> PF:
    """Rename the literals of a formula (``fn`` maps a positive literal to a positive one)."""
    if type(f) is int:
        return fn(f) if f > 0 else -fn(-f)
    if type(f) is bool:
        return f
    return (f[0], tuple(map_lits(g, fn) for g in f[1]))  # type: ignore[index]


def lits_of(f: PF, acc: set | None = None) -> set:
    acc = set() if acc is None else acc
    if type(f) is int:
        acc.add(abs(f))
    elif type(f) is tuple:
        for g in f[1]:
            lits_of(g, acc)
    return acc
