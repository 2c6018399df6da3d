"""Integer identities for ground atoms.

A Boolean ground constant is one atom (``c`` true is ``+id``, false is ``-id``); a
non-Boolean one has an atom per value of its domain (``c=v`` is ``+id``).  Time is not
part of an atom: the grounder pairs an atom with a step slot, the SAT layer with a step.
"""
from __future__ import annotations

from cplus.signature import GroundConst, Signature

__all__ = ["AtomTable"]


class AtomTable:
    """Atoms of every ground constant of a signature (and of hidden ones added later)."""

    def __init__(self, sig: Signature) -> None:
        self.sig = sig
        self.gc_of: list[GroundConst | None] = [None]
        self.value_of: list[object] = [None]
        self._by_gc: dict[int, object] = {}
        for gc in sig.ground:
            self.add(gc)

    def __len__(self) -> int:
        return len(self.gc_of) - 1

    def add(self, gc: GroundConst) -> None:
        if gc.id in self._by_gc:
            return
        if gc.boolean:
            self._by_gc[gc.id] = len(self.gc_of)
            self.gc_of.append(gc)
            self.value_of.append(None)
        else:
            ids = {}
            for v in gc.domain:
                ids[v] = len(self.gc_of)
                self.gc_of.append(gc)
                self.value_of.append(v)
            self._by_gc[gc.id] = ids

    def lit(self, gc: GroundConst, value: object) -> int:
        """Signed atom id of ``gc=value``; 0 when the value is outside the domain."""
        entry = self._by_gc[gc.id]
        if type(entry) is int:
            if value == "true":
                return entry
            if value == "false":
                return -entry
            return 0
        return entry.get(value, 0)  # type: ignore[attr-defined]

    def atoms(self, gc: GroundConst) -> list[int]:
        """Positive atom ids of a ground constant (one for a Boolean constant)."""
        entry = self._by_gc[gc.id]
        return [entry] if type(entry) is int else list(entry.values())  # type: ignore[attr-defined]

    def head_lits(self, gc: GroundConst) -> list[tuple[int, object]]:
        """Every literal that can be a head for ``gc`` with the value it stands for."""
        entry = self._by_gc[gc.id]
        if type(entry) is int:
            return [(entry, "true"), (-entry, "false")]
        return [(aid, v) for v, aid in entry.items()]  # type: ignore[attr-defined]
