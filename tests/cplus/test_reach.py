"""Pruning fluent values unreachable from the query's initial state (cplus.sat.reach) never
changes the histories, and it does prune what cannot happen."""
from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.sat import horizon
from cplus.sat.reach import unreachable

JUGS = """
:- sorts jug; amount.
:- objects a, b, c :: jug; 0..8 :: amount.
:- variables J, K :: jug; L, L1 :: amount.
:- constants level(jug) :: inertialFluent(amount); pour(jug, jug) :: exogenousAction.
pour(J, b) causes level(b) = L1 + L if level(J) = L & level(b) = L1 where J \\= b & L1 + L =< 5.
pour(J, b) causes level(J) = 0 if level(J) = L & level(b) = L1 where J \\= b & L1 + L =< 5.
pour(J, b) causes level(b) = 5 if level(J) = L & level(b) = L1 where J \\= b & L1 + L > 5 & L1 =< 5.
pour(J, b) causes level(J) = L - (5 - L1) if level(J) = L & level(b) = L1 where J \\= b & L1 + L > 5 & L1 =< 5.
pour(J, a) causes level(a) = L1 + L if level(J) = L & level(a) = L1 where J \\= a & L1 + L =< 8.
pour(J, a) causes level(J) = 0 if level(J) = L & level(a) = L1 where J \\= a & L1 + L =< 8.
nonexecutable pour(J, J).
nonexecutable pour(J, c).
constraint level(b) =< 5.
noconcurrency.
:- query maxstep :: 4; 0: level(a) = 8 & level(b) = 0 & level(c) = 0.
"""


def counts(text: str) -> tuple[int, int]:
    pruned = Domain.from_text(text).solve(solutions=0)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(horizon, "unreachable", lambda theory, fixed: set())
        d = Domain.from_text(text)
        assert d.theory.initial is None     # every instance ground: solve uses it, unpruned
        full = d.solve(solutions=0)
    assert {h.key() for h in pruned.histories} == {h.key() for h in full.histories}
    return len(pruned.histories), len(full.histories)


def test_jugs_keep_their_histories_and_lose_impossible_levels():
    n, m = counts(JUGS)
    assert n == m > 1
    d = Domain.from_text(JUGS)
    th = d.theory
    level_c = next(gc for gc in th.sig.ground if gc.text == "level(c)")
    fixed = {th.atoms.lit(gc, v) for gc, v in
             [(g, 8 if g.text == "level(a)" else 0) for g in th.sig.ground if g.decl.name == "level"]}
    dead = unreachable(th, fixed)
    # nothing is ever poured into c: it stays empty
    assert {th.atoms.value_of[a] for a in dead if th.atoms.gc_of[a] is level_c} == set(range(1, 9))


@st.composite
def domains(draw):
    top = draw(st.integers(2, 6))
    laws = []
    for _ in range(draw(st.integers(1, 4))):
        act = draw(st.sampled_from(["a", "b"]))
        cst = draw(st.sampled_from(["x", "y"]))
        k = draw(st.integers(1, 3))
        op = draw(st.sampled_from(["+", "-", "*"]))
        laws.append(f"{act} causes {cst} = N {op} {k} if {cst} = N where N {op} {k} >= 0 & N {op} {k} =< {top}.")
    if draw(st.booleans()):
        laws.append(f"caused s = N + M if x = N & y = M where N + M =< {top}.")
        laws.append("default s = 0.")
    if draw(st.booleans()):
        laws.append(f"constraint x \\= {draw(st.integers(0, top))}.")
    x0, y0 = draw(st.integers(0, top)), draw(st.integers(0, top))
    m = draw(st.integers(0, 3))
    fix = f"0: x = {x0} & y = {y0}" if draw(st.booleans()) else f"0: x = {x0}"
    return (f":- sorts n. :- objects 0..{top} :: n. :- variables N, M :: n.\n"
            ":- constants x, y :: inertialFluent(n); s :: sdFluent(n); a, b :: exogenousAction.\n"
            + "\n".join(laws) + f"\n:- query maxstep :: {m}; {fix}.\n")


@settings(max_examples=60)
@given(domains())
def test_pruning_never_changes_the_histories(text):
    n, m = counts(text)
    assert n == m


def test_a_disjunctive_body_needs_only_one_of_its_atoms():
    """``x = 3`` is caused when y is 1 or 2; y is only ever 1, so 3 is reachable (a
    conjunctive reading of the body would prune it and lose the history)."""
    text = (":- sorts n. :- objects 0..3 :: n.\n"
            ":- constants x :: inertialFluent(n); y :: inertialFluent(n); go :: exogenousAction.\n"
            "go causes x = 3 if y = 1 ++ y = 2.\n"
            ":- query maxstep :: 1; 0: x = 0 & y = 1; 1: x = 3.\n")
    n, m = counts(text)
    assert n == m == 1
