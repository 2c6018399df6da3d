"""Plain data classes for the modules every command imports, without :mod:`dataclasses`.

Importing :mod:`dataclasses` (it imports inspect, and with it ast, dis and tokenize) and
building the planning path's 21 data classes with it cost every ``cplus plan`` about 14 ms
of start-up: tanks-200 took 81 ms in all, against 70 ms for the peer.  Those classes write
their ``__init__`` by hand and derive from :class:`Record`, which gives what the dataclasses
gave: equality and a hash over the fields (``_compare``, by default every field in
``_fields``), and a repr.  Modules that only some commands import (robot tasks, trajectories,
the NXT link) keep their dataclasses.
"""
from __future__ import annotations

from collections.abc import Callable
from operator import attrgetter

__all__ = ["Record"]


class Record:
    """Value equality, hashing and repr over ``_compare`` (by default ``_fields``).  A record
    whose fields change after it is made is not hashed (as a mutable dataclass was not)."""

    __slots__ = ()
    _fields: tuple[str, ...] = ()
    _compare: tuple[str, ...] | None = None
    _key: Callable[[object], object] = staticmethod(lambda record: ())
    """A record's compared values, in one C call (an ``operator.attrgetter``; not a method)."""

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        names = cls._compare if cls._compare is not None else cls._fields
        if names:
            cls._key = attrgetter(*names)

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        key = self._key
        return key(self) == key(other)

    def __hash__(self) -> int:
        return hash(self._key(self))

    def __repr__(self) -> str:
        names = self._compare if self._compare is not None else self._fields
        return f"{type(self).__name__}({', '.join(f'{n}={getattr(self, n)!r}' for n in names)})"
