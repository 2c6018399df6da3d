"""Model counts of small domains: hand-checked ones, and random ones against the oracle.

The planner (completion, CNF, incremental solver, history enumeration) must agree with a
brute-force enumeration of the models of the causal theory (``cplus_oracle``).
"""
from __future__ import annotations

import pytest
from cplus_oracle import models
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.planner import run_query
from cplus.program import QuerySpec


def count(text: str, label: str = "0") -> tuple[int | None, int]:
    d = Domain.from_text(text)
    r = d.solve(label, solutions=0)
    return r.maxstep, len(r.histories)


def planner_count(domain: Domain, m: int) -> int:
    r = run_query(domain.theory, QuerySpec("all", m, m, (), None), solutions=0)
    return len(r.histories)


LAMP = """
:- constants lit :: inertialFluent; flip :: exogenousAction.
flip causes lit.
"""


def test_worked_example_one_has_three_histories():
    """cplus-language.md D.6: with 1: lit asserted there are exactly three histories."""
    assert count(LAMP + ":- query maxstep :: 1; 1: lit.") == (1, 3)


def test_worked_example_two_swings_four_histories():
    """D.6: a pendulum that swings unless held: from 0: -s, maxstep 2, four histories."""
    text = """
:- constants s :: simpleFluent; h :: exogenousAction.
default s after -s.
default -s after s.
h causes s if s.
h causes -s if -s.
:- query maxstep :: 2; 0: -s.
"""
    assert count(text) == (2, 4)


@pytest.mark.parametrize("text, expected", [
    # a plain action needs a cause for both values: with none, no history of length 1
    (":- constants p :: inertialFluent; a :: action. :- query maxstep :: 1.", (None, 0)),
    # ... and with `default -a` it is simply never done
    (":- constants p :: inertialFluent; a :: action. default -a. :- query maxstep :: 1.", (1, 2)),
    # a simple fluent with no law at step 1 has no model
    (":- constants p :: simpleFluent. :- query maxstep :: 1.", (None, 0)),
    # an sdFluent needs static laws at every step including 0
    (":- constants q :: sdFluent. :- query maxstep :: 0.", (None, 0)),
    (":- constants q :: sdFluent; p :: inertialFluent. caused q if p. default -q. :- query maxstep :: 0.",
     (0, 2)),
    # a rigid constant needs exogenous, default or facts
    (":- constants c :: rigid. :- query maxstep :: 0.", (None, 0)),
    (":- constants c :: rigid. exogenous c. :- query maxstep :: 0.", (0, 2)),
    # attributes: none exactly when the action is not done (1 + 3 action choices)
    (":- constants a :: exogenousAction; k :: attribute(1..3) of a; p :: inertialFluent. "
     ":- query maxstep :: 1; 0: p.", (1, 4)),
    # noconcurrency: at most one of three actions per step (4 choices instead of 8)
    (":- constants p :: inertialFluent; a, b, c :: exogenousAction. noconcurrency. "
     ":- query maxstep :: 1; 0: p.", (1, 4)),
    # may cause: nondeterministic effect
    (":- constants p :: inertialFluent; a :: exogenousAction. a may cause p. "
     ":- query maxstep :: 1; 0: -p & a.", (1, 2)),
    # always restricts actions 0..m-1 only; constraint restricts every state
    (":- constants p :: inertialFluent; a :: exogenousAction. always a. :- query maxstep :: 2; 0: p.", (2, 1)),
    (":- constants p :: inertialFluent; a :: exogenousAction. a causes -p. constraint p. "
     ":- query maxstep :: 1.", (1, 1)),
    # additive fluent: the value after is the sum of the contributions
    (":- maxAdditive :: 5. :- constants n :: additiveFluent(0..5); a, b :: exogenousAction. "
     "a increments n by 2. b increments n by 1. :- query maxstep :: 1; 0: n=1; 1: n=4.", (1, 1)),
    # ... and a sum outside the domain makes the step impossible
    (":- maxAdditive :: 5. :- constants n :: additiveFluent(0..5); a, b :: exogenousAction. "
     "a increments n by 3. b increments n by 3. :- query maxstep :: 1; 0: n=0 & a & b.", (None, 0)),
    # unless: the abnormality defaults to false, a law can cause it
    (":- constants p :: inertialFluent; a, b :: exogenousAction. a causes p unless ab. caused ab if b. "
     ":- query maxstep :: 1; 0: -p & a & b; 1: -p.", (1, 1)),
    # rigid law on a fluent: it never changes
    (":- constants p :: simpleFluent; a :: exogenousAction. rigid p. a may cause p. a may cause -p. "
     "default p after p. default -p after -p. :- query maxstep :: 2; 0: p; 2: -p.", (None, 0)),
    # maxstep ranges stop at the first length with a history
    (LAMP + ":- query maxstep :: 0..5; 0: -lit; maxstep: lit.", (1, 1)),
    # a quantified condition over a sort
    (":- sorts room. :- objects k, h :: room. :- variables R :: room. "
     ":- constants lit(room) :: inertialFluent; flip(room) :: exogenousAction. "
     "flip(R) causes lit(R). :- query maxstep :: 1; 0: [/\\R | -lit(R)]; 1: [\\/R | lit(R)].", (1, 3)),
])
def test_small_domains(text, expected):
    assert count(text) == expected


def test_histories_are_distinct_even_with_auxiliary_variables():
    """A disjunctive body gets a Tseitin variable; histories still count once."""
    text = """
:- constants p, q, r :: inertialFluent; a :: exogenousAction.
caused r if p ++ q.
default -r.
a causes p.
:- query maxstep :: 1.
"""
    d = Domain.from_text(text)
    keys = [h.key() for h in d.solve(solutions=0).histories]
    assert len(keys) == len(set(keys)) == len(models(d.theory, 1))


def test_a_constant_inside_a_head_argument():
    """`caused g(f)` causes g(v) for the value v of f (C.8: the constant moves to the body)."""
    text = """
:- sorts s. :- objects a, b :: s. :- variables X :: s.
:- constants f :: inertialFluent(s); g(s) :: sdFluent.
caused g(f).
default -g(X).
:- query maxstep :: 0; 0: f=a.
"""
    (hist,) = Domain.from_text(text).solve(solutions=0).histories
    assert hist.value("g(a)", 0) is True and hist.value("g(b)", 0) is False


def test_negative_values_and_nested_constants():
    text = """
:- sorts node. :- objects 1..3 :: node. :- variables X, Y :: node.
:- constants f :: node; g(node) :: node.
exogenous f. exogenous g(X).
constraint g(f) = 2.
:- query maxstep :: 0.
"""
    d = Domain.from_text(text)
    assert len(d.solve(solutions=0).histories) == len(models(d.theory, 0)) == 3 * 9


# --------------------------------------------------------------------------- random domains

FLUENT_KINDS = ["inertialFluent", "simpleFluent", "sdFluent"]
ACTION_KINDS = ["exogenousAction", "action"]


@st.composite
def domains(draw):
    nf = draw(st.integers(1, 3))
    na = draw(st.integers(1, 2))
    fl = [f"f{i}" for i in range(nf)]
    ac = [f"a{i}" for i in range(na)]
    kinds = {f: draw(st.sampled_from(FLUENT_KINDS)) for f in fl}
    dyn = [f for f in fl if kinds[f] != "sdFluent"] or None   # heads of laws with 'after'
    decls = [f"{f} :: {kinds[f]}" for f in fl]
    decls += [f"{a} :: {draw(st.sampled_from(ACTION_KINDS))}" for a in ac]
    multi = draw(st.booleans())          # a three-valued inertial fluent v
    if multi:
        decls.append("v :: inertialFluent(0..2)")

    def lit(names, head=False):
        if multi and names is not ac and draw(st.integers(0, 3)) == 0:
            atom = f"v={draw(st.integers(0, 2))}"
            return atom if head or draw(st.booleans()) else f"-({atom})"
        n = draw(st.sampled_from(names))
        return n if draw(st.booleans()) else "-" + n

    def formula(names, depth=0):
        if depth >= 2 or draw(st.integers(0, 2)) == 0:
            return lit(names)
        op = draw(st.sampled_from(["&", "++", "->>"]))
        return f"({formula(names, depth + 1)} {op} {formula(names, depth + 1)})"

    laws = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.integers(0, 9))
        if dyn is None and kind in (1, 2, 5, 9):
            kind = 0
        if kind == 0:
            laws.append(f"caused {lit(fl, True)} if {formula(fl)}.")
        elif kind == 1:
            laws.append(f"caused {lit(dyn, True)} if {formula(fl)} after {formula(fl + ac)}.")
        elif kind == 2:
            laws.append(f"{draw(st.sampled_from(ac))} causes {lit(dyn, True)} if {formula(fl)}.")
        elif kind == 3:
            laws.append(f"nonexecutable {draw(st.sampled_from(ac))} if {formula(fl)}.")
        elif kind == 4:
            laws.append(f"default {lit(fl, True)}.")
        elif kind == 5:
            laws.append(f"default {lit(dyn, True)} after {formula(fl + ac)}.")
        elif kind == 6:
            laws.append(f"constraint {formula(fl)}.")
        elif kind == 7:
            laws.append(f"always {formula(fl + ac)}.")
        elif kind == 8:
            laws.append(f"caused {lit(ac)} if {formula(fl + ac)}.")
        else:
            laws.append(f"{draw(st.sampled_from(ac))} may cause {lit(dyn, True)}.")
    for a in ac:
        if draw(st.booleans()):
            laws.append(f"default -{a}.")
    return ":- constants " + "; ".join(decls) + ".\n" + "\n".join(laws) + "\n"


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(domains(), st.integers(0, 2))
def test_planner_agrees_with_the_oracle_on_random_domains(text, m):
    d = Domain.from_text(text)
    assert planner_count(d, m) == len(models(d.theory, m)), text
