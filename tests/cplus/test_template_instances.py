"""How a horizon places its templates (cplus.sat.horizon): each step's clauses are the
transition template's clauses with every literal renamed to the solver variable of the same
atom at that step (negated literals included), the static part first, and every clause
arrives whole however the solver is handed them."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.sat.horizon import Horizon
from cplus.sat.solver import SatSolver
from cplus.sat.templates import build_templates

SOURCE = """
:- sorts loc.
:- objects a, b, c :: loc.
:- variables L, L1 :: loc.
:- constants at :: inertialFluent(loc); lit :: inertialFluent; go(loc) :: exogenousAction; dark :: sdFluent.
go(L) causes at = L.
nonexecutable go(L) & go(L1) where L @< L1.
nonexecutable go(L) if at = L.
go(a) causes lit.
caused dark if -lit.
default -dark.
:- query maxstep :: 2; 0: at = a & -lit.
"""


class Recorder:
    """Stands in for the solver: keeps every clause as a list."""

    def __init__(self, name: str = "") -> None:
        self.clauses: list[list[int]] = []

    def add_clause(self, clause) -> None:
        self.clauses.append(list(clause))

    def add_clauses(self, clauses) -> None:
        self.clauses.extend(list(c) for c in clauses)

    @property
    def count(self) -> int:
        return len(self.clauses)

    def delete(self) -> None:
        pass


def expected(tpl, base_top: int, R: int, N: int, b0: int, b1: int, aux: int) -> list[list[int]]:
    """The clauses of one instance, renamed literal by literal."""
    def var(x: int) -> int:
        if x <= R:
            return x
        if x <= R + N:
            return b0 + x - R - 1
        if x <= base_top:
            return b1 + x - R - N - 1
        return aux + x - base_top - 1
    return [[var(x) if x > 0 else -var(-x) for x in c] for c in tpl.clauses]


def test_each_step_is_the_transition_renamed_to_its_blocks():
    domain = Domain.from_text(SOURCE)
    theory = domain.theory_for(domain.query("0"))
    templates = build_templates(theory)
    layout, _, _, trans = templates
    h = Horizon(theory, solver_factory=Recorder, templates=templates)
    for t in range(3):
        before, top = len(h.solver.clauses), h.top
        h.extend_to(t + 1)
        b0, b1 = h.blocks[t], h.blocks[t + 1]
        aux = top + layout.N + 1
        want = []
        part_aux = aux + trans.top - layout.base_top
        for part, slot in trans.extra:
            b = b1 if slot == 1 else b0
            want += expected(part, layout.base_top, layout.R, layout.N, b, b, part_aux)
            part_aux += part.top - layout.base_top
        want += expected(trans, layout.base_top, layout.R, layout.N, b0, b1, aux)
        assert h.solver.clauses[before:] == want
        assert any(x < 0 for c in want for x in c) and any(x > 0 for c in want for x in c)
        assert h.top == part_aux - 1


@settings(max_examples=30, deadline=None)
@given(st.lists(st.lists(st.integers(-6, 6).filter(bool), min_size=1, max_size=4), max_size=20))
def test_add_clauses_takes_any_iterables_and_counts_them(clauses):
    with SatSolver() as one, SatSolver() as many:
        for c in clauses:
            one.add_clause(c)
        many.add_clauses(map(iter, clauses))
        assert many.count == one.count == len(clauses)
        assert many.solve() == one.solve()
        if one.solve():
            assert all(any(many.value(abs(x)) == (x > 0) for x in c) for c in clauses)


def test_building_templates_leaves_the_garbage_collector_as_it_was():
    import gc
    domain = Domain.from_text(SOURCE)
    theory = domain.theory_for(domain.query("0"))
    assert gc.isenabled()
    build_templates(theory)
    assert gc.isenabled()
    gc.disable()
    try:
        build_templates(theory)
        assert not gc.isenabled()
    finally:
        gc.enable()
