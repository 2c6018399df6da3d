"""Grounding restricted to what a query's initial state can reach (cplus.ground.restrict)
keeps exactly the rules the templates would keep from the full grounding, finds exactly the
values cplus.sat.reach finds unreachable, and never changes the histories."""
from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.ground.atoms import AtomTable
from cplus.ground.restrict import fixed_at_zero
from cplus.ground.theory import ground_program
from cplus.load import load_program, load_text
from cplus.sat.reach import unreachable
from cplus.sat.templates import _needs_dead

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "bench" / "data"
CORPUS = ROOT / "tests" / "corpus" / "domains" / "examples"


def kept(theory, dead) -> tuple[dict, dict]:
    """The rules and constraints the templates use, as multisets, per class."""
    rules = {cls: Counter(repr((c, b)) for c, b in rs if not ((c > 0 and (c - 1) // 3 in dead) or _needs_dead(dead, b)))
             for cls, rs in theory.rules.items()}
    cons = {cls: Counter(repr(b) for b in cs if not _needs_dead(dead, b)) for cls, cs in theory.constraints.items()}
    return rules, cons


def compare(load, label: str = "0") -> tuple[int, int]:
    """Ground in full and restricted from two loads of the same source; check they agree.
    Returns (rules in full, rules restricted)."""
    full_prog, prog = load(), load()
    query = full_prog.query(label)
    full = ground_program(full_prog)
    fixed = fixed_at_zero(full.sig, full.atoms, query)
    assert fixed, "the query fixes part of the initial state"
    assert fixed == fixed_at_zero(prog.signature, AtomTable(prog.signature), prog.query(label))
    dead = unreachable(full, fixed)
    restricted = ground_program(prog, fixed)
    assert restricted.initial == frozenset(fixed)
    assert set(restricted.dead) == dead
    assert kept(restricted, restricted.dead) == kept(full, dead)
    assert restricted.sums and full.sums or not full.sums
    return full.rule_count, restricted.rule_count


@pytest.mark.parametrize("path", [
    BENCH / "tanks-200.cp", BENCH / "car-300.cp",
    CORPUS / "benchmarks" / "spacecraft-15-8" / "spacecraft-15-8-benchmark.cp",
    CORPUS / "benchmarks" / "ferryman-10-4" / "ferryman-10-4-benchmark.cp",
    CORPUS / "benchmarks" / "blocks-bench-15" / "bw-15-benchmark.cp",
], ids=lambda p: p.stem)
def test_benchmarks_keep_the_same_rules(path):
    full, restricted = compare(lambda: load_program(str(path)))
    assert restricted <= full


def test_tanks_ground_only_reachable_levels():
    full, restricted = compare(lambda: load_program(str(BENCH / "tanks-200.cp")))
    assert restricted * 100 < full        # 19 of 603 levels are reachable from 200/0/0


@st.composite
def domains(draw):
    top = draw(st.integers(2, 4))
    k = lambda: draw(st.integers(0, top))  # noqa: E731
    laws = []
    pool = [
        f"a causes x = N + 1 if x = N where N + 1 =< {top}.",
        f"b causes x = N - {draw(st.integers(1, 2))} if x = N & y = M where N - M >= 0.",
        f"act(K) causes f(K) = N + K if f(K) = N where N + K =< {top}.",
        f"act(K) causes y = N if f(K) = N & x = {k()}.",
        f"caused s = N + M if x = N & y = M where N + M =< {top}.",
        "default s = 0.",
        f"caused s = {k()} if f(1) = N & f(2) = N.",
        f"caused x = N if x = N after y = N & x = {k()}.",
        f"caused -p after x = {k()}.",
        f"a causes p if y = N where N > {k()}.",
        "caused s = N if p & x = N.",
        f"constraint -(x = N & y = N) where N > {k()}.",
        f"nonexecutable a if y = N where N >= {k()}.",
        f"a causes y = {k()} if x = {k()}.",
        "caused g = N if f(K) = N & f(K1) = N where K < K1.",
        f"caused g = {k()} if -(x = {k()}).",
        "exogenous y." if draw(st.booleans()) else f"constraint y \\= {top}.",
    ]
    for law in draw(st.lists(st.sampled_from(pool), min_size=1, max_size=6, unique=True)):
        laws.append(law)
    fix = [f"x = {k()}"]
    if draw(st.booleans()):
        fix.append(f"y = {k()}")
    if draw(st.booleans()):
        fix.append(f"f(1) = {k()} & f(2) = {k()}")
    m = draw(st.integers(0, 3))
    return (f":- sorts n; k. :- objects 0..{top} :: n; 1..2 :: k. :- variables N, M :: n; K, K1 :: k.\n"
            ":- constants x, y :: inertialFluent(n); f(k) :: inertialFluent(n); s, g :: sdFluent(n); p :: inertialFluent;\n"
            "   a, b :: exogenousAction; act(k) :: exogenousAction.\n"
            + "\n".join(laws) + f"\nnoconcurrency.\n:- query maxstep :: {m}; 0: {' & '.join(fix)}.\n")


HISTORIES = 2000


@settings(max_examples=80, deadline=None)
@given(domains())
def test_restricted_grounding_keeps_rules_values_and_histories(text):
    compare(lambda: load_text(text))
    restricted = Domain.from_text(text)
    # every history is enumerated, and a draw with free fluents over a wide range has
    # millions (one took minutes and gigabytes): those are left out
    pruned = restricted.solve(solutions=HISTORIES + 1)
    assume(len(pruned.histories) <= HISTORIES)
    assert restricted._theory is None          # solve did not need the full grounding
    full = Domain.from_text(text)
    assert full.theory.initial is None
    every = full.solve(solutions=HISTORIES + 1)
    assert pruned.maxstep == every.maxstep
    assert sorted(h.key() for h in pruned.histories) == sorted(h.key() for h in every.histories)


ADDITIVE = """
:- maxAdditive :: 4.
:- sorts n. :- objects 0..4 :: n. :- variables N :: n.
:- constants money :: additiveFluent(n); fuel :: inertialFluent(n);
   earn, spend :: exogenousAction.
earn increments money by 2.
spend decrements money by 1.
earn causes fuel = N + 2 if fuel = N where N + 2 =< 4.
:- query label :: low; maxstep :: 0..3; 0: money = 0 & fuel = 0; maxstep: money = 3.
:- query label :: high; maxstep :: 0..3; 0: money = 4 & fuel = 3; maxstep: money = 1.
"""


def test_a_program_ground_for_several_states_shares_its_hidden_constants():
    d = Domain.from_text(ADDITIVE)
    low = d.solve("low", solutions=0)
    n = len(d.program.signature.ground)
    high = d.solve("high", solutions=0)
    assert len(d.program.signature.ground) == n      # the contributions were made once
    assert len(d._for_state) == 2
    every_low = d.theory and d.solve("low", solutions=0)   # now the full grounding
    assert len(d.program.signature.ground) == n
    for result, label in ((low, "low"), (high, "high"), (every_low, "low")):
        fresh = Domain.from_text(ADDITIVE)
        assert fresh.theory.initial is None
        expected = fresh.solve(label, solutions=0)
        assert result.maxstep == expected.maxstep
        assert sorted(h.key() for h in result.histories) == sorted(h.key() for h in expected.histories)
    assert low.maxstep == 2 and high.maxstep == 3


def test_a_theory_for_one_state_refuses_another():
    from cplus.planner import run_query
    d = Domain.from_text(ADDITIVE)
    theory = d.theory_for(d.query("low"))
    assert theory.initial is not None and theory.dead
    with pytest.raises(ValueError, match="another initial state"):
        run_query(theory, d.query("high"))
