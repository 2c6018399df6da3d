"""External functions and predicates, the one part of a domain that is not C+ text.

Apart from the statement resolvers because its users are elsewhere: the command line fills a
registry from ``--extern`` files (:mod:`cplus.externals`), robot tasks add their own, and the
resolver only looks names up in it.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

from cplus.record import Record


class External(Record):
    """``predicate`` True: formulas only; False: terms only; None: either."""

    _fields = ("name", "arity", "fn", "predicate")

    name: str
    arity: int
    fn: Callable[..., object]
    predicate: bool | None

    def __init__(self, name: str, arity: int, fn: Callable[..., object], predicate: bool | None) -> None:
        self.name = name
        self.arity = arity
        self.fn = fn
        self.predicate = predicate


class Externals:
    """Registry of external functions and predicates usable in laws (``collision/4``)."""

    def __init__(self, items: Iterable[External] = ()) -> None:
        self._items: dict[tuple[str, int], External] = {(e.name, e.arity): e for e in items}

    def add(self, ext: External) -> None:
        self._items[(ext.name, ext.arity)] = ext

    def add_predicate(self, name: str, arity: int, fn: Callable[..., object]) -> None:
        self.add(External(name, arity, fn, True))

    def get(self, name: str, arity: int) -> External | None:
        return self._items.get((name, arity))

    def copy(self) -> Externals:
        return Externals(self._items.values())


def _between(lo: object, hi: object, x: object) -> bool:
    return isinstance(lo, int) and isinstance(hi, int) and isinstance(x, int) and lo <= x <= hi


BUILTIN_EXTERNALS = Externals([External("between", 3, _between, True)])
