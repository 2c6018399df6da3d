"""The CNF of one horizon in DIMACS form, with a model per history.

Every auxiliary variable is defined by an equivalence and unused variable numbers are
dropped, so the models of the written formula correspond one to one to the histories of
length m (answering the query, if one is given).  Comment lines name the atom of each
variable: ``c 17 3:loc(d1)=table``.
"""
from __future__ import annotations

from typing import TextIO

from cplus.ground.theory import GroundTheory
from cplus.program import QuerySpec
from cplus.sat.horizon import QuerySession
from cplus.signature import render_value

__all__ = ["ClauseCollector", "horizon_cnf", "write_dimacs"]


class ClauseCollector:
    """Stands in for the solver when the clauses are only to be written out."""

    def __init__(self, name: str = "") -> None:
        self.clauses: list[list[int]] = []
        self.name = "collector"

    def add_clause(self, clause: list[int]) -> None:
        self.clauses.append(list(clause))

    def add_clauses(self, clauses) -> None:
        self.clauses.extend(list(c) for c in clauses)

    @property
    def count(self) -> int:
        return len(self.clauses)


def horizon_cnf(theory: GroundTheory, maxstep: int, query: QuerySpec | None = None):
    """(number of variables, clauses, names) of D_maxstep plus the query's conditions."""
    q = query or QuerySpec("domain", maxstep, maxstep, (), None)
    session = QuerySession(theory, q, solver_factory=ClauseCollector)
    session.horizon.extend_to(maxstep, query.loc if query else None)
    session.assert_items(maxstep)
    h = session.horizon
    clauses = h.solver.clauses
    names: dict[int, str] = {}
    atoms = theory.atoms
    for aid in h.layout.rigid_atoms:
        names[h.var(aid, None)] = _atom_name(atoms, aid, None)
    for aid in h.layout.step_atoms:
        gc = atoms.gc_of[aid]
        last = maxstep - 1 if gc.decl.is_action else maxstep  # type: ignore[union-attr]
        for t in range(last + 1):
            names[h.var(aid, t)] = _atom_name(atoms, aid, t)
    used = {abs(x) for c in clauses for x in c} | set(names)
    renumber = {v: i for i, v in enumerate(sorted(used), start=1)}
    out = [[renumber[x] if x > 0 else -renumber[-x] for x in c] for c in clauses]
    return len(renumber), out, {renumber[v]: n for v, n in names.items()}


def _atom_name(atoms, aid: int, t: int | None) -> str:
    gc = atoms.gc_of[aid]
    v = atoms.value_of[aid]
    text = gc.text if v is None else f"{gc.text}={render_value(v)}"
    return text if t is None else f"{t}:{text}"


def write_dimacs(fh: TextIO, nvars: int, clauses: list[list[int]], names: dict[int, str]) -> None:
    for v in sorted(names):
        fh.write(f"c {v} {names[v]}\n")
    fh.write(f"p cnf {nvars} {len(clauses)}\n")
    for c in clauses:
        fh.write(" ".join(map(str, c)) + " 0\n")
