"""Grounding and encoding only what the query's start can reach never changes the
histories: on random domains, the history sets (every history, -n 0) are those of the full
grounding with every value encoded at every step.  Causal rules are completed, so values
that support each other within a step (a loop of static laws) are reachable from any start."""
from __future__ import annotations

import pytest
from cplus_random import descriptions
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.ground.restrict import Reachability, cyclic_fluents
from cplus.load import load_text
from cplus.sat import horizon

LOOP = """
:- sorts n. :- objects 0..1 :: n.
:- constants f, g :: sdFluent(n); a :: exogenousAction.
caused f=0 if g=0. caused f=1 if g=1.
caused g=0 if f=0. caused g=1 if f=1.
:- query maxstep :: 1; 0: f=0.
"""


# Histories are enumerated one solver call each: a random domain with few laws can have
# 196,608 of them (five free Boolean fluents, two exogenous actions, maxstep 2), which took
# over ten minutes on a loaded machine.  Every history up to this many, and one more to tell.
MOST = 600


def histories(text: str, label: str = "0") -> tuple[int | None, set]:
    r = Domain.from_text(text).solve(label, solutions=MOST + 1)
    return r.maxstep, {h.key() for h in r.histories}


def full_histories(text: str, label: str = "0") -> tuple[int | None, set]:
    """The histories of the full grounding, every value encoded at every step."""
    with pytest.MonkeyPatch.context() as m:
        m.setattr(horizon, "unreachable", lambda theory, fixed: set())
        d = Domain.from_text(text)
        assert d.theory.initial is None     # every instance ground: solve uses it, unpruned
        r = d.solve(label, solutions=MOST + 1)
    return r.maxstep, {h.key() for h in r.histories}


def test_values_in_a_loop_of_static_laws_stay_possible():
    """f=g=1 at step 1 supports itself; pruning it (nothing leads there from f=0) lost two
    of the four histories."""
    found = histories(LOOP)
    assert found == full_histories(LOOP)
    assert len(found[1]) == 4


def test_a_loop_through_a_dynamic_laws_if_part_stays_possible():
    text = (LOOP.replace("caused g=1 if f=1.", "caused g=1 if f=1 after a.").replace("maxstep :: 1; 0: f=0", "maxstep :: 2; 0: f=0 & g=0")
            .replace("f, g :: sdFluent(n)", "f :: sdFluent(n); g :: simpleFluent(n)"))
    found = histories(text)
    assert found == full_histories(text)
    assert len(found[1]) == 9        # f=g=1 at step 1 or 2 (after a), or neither


def decls(text: str) -> dict[str, bool]:
    prog = load_text(text)
    sig = prog.signature
    cands = {id(gc.decl): gc.decl for gc in sig.ground if not gc.boolean and gc.decl.is_fluent}
    cyclic = cyclic_fluents(prog.laws, cands)
    return {d.name: id(d) in cyclic for d in cands.values()}


HEAD = ":- sorts n; k. :- objects 0..2 :: n; p, q :: k. :- variables V :: n; X, Y :: k.\n"


def test_a_rule_that_is_its_own_body_is_no_loop():
    assert decls(HEAD + ":- constants c :: sdFluent(n). caused c = V if c = V.") == {"c": False}
    assert decls(HEAD + ":- constants c :: simpleFluent(n). exogenous c.") == {"c": False}
    assert decls(HEAD + ":- constants c :: inertialFluent(n). inertial c.") == {"c": False}


def test_loops_are_found_through_instances_comparisons_and_arguments():
    assert decls(HEAD + ":- constants c(k) :: sdFluent(n). caused c(X) = V if c(Y) = V.") == {"c": True}
    assert decls(HEAD + ":- constants c, d :: sdFluent(n). caused c = 2 if d >= 2. caused d = 2 if c >= 2.") \
        == {"c": True, "d": True}
    assert decls(HEAD + ":- constants c :: sdFluent(n); e :: sdFluent(k); h(k) :: sdFluent(n).\n"
                 "caused h(e) = 1. caused e = p if h(p) = 1.") == {"c": False, "e": True, "h": True}
    assert decls(HEAD + ":- constants c, d :: inertialFluent(n); a :: exogenousAction.\n"
                 "caused c = V if d = V. caused d = V after a & c = V.") == {"c": False, "d": False}


def test_a_loop_leaves_every_value_possible_at_the_start():
    prog = load_text(LOOP)
    from cplus.ground.atoms import AtomTable
    atoms = AtomTable(prog.signature)
    f = next(gc for gc in prog.signature.ground if gc.text == "f")
    zero = atoms.lit(f, 0)
    assert Reachability(prog.signature, atoms, {zero}).closed          # without the laws: f=1 closed
    assert not Reachability(prog.signature, atoms, {zero}, prog.laws).closed


@st.composite
def loops(draw):
    """Fluents over 0..1 with static, dynamic and action laws drawn between them, the
    initial state fixed but for some statically determined fluents: loops of support within
    a step come often."""
    kinds = [draw(st.sampled_from(["sdFluent", "sdFluent", "inertialFluent", "simpleFluent"])) for _ in range(3)]
    names = ["x", "y", "z"][:draw(st.integers(2, 3))]
    laws = []
    for _ in range(draw(st.integers(0, 5))):
        h, b = draw(st.sampled_from(names)), draw(st.sampled_from(names))
        i, j = draw(st.integers(0, 1)), draw(st.integers(0, 1))
        form = draw(st.sampled_from(["static", "static", "cause", "after"]))
        if form == "static" or kinds[names.index(h)] == "sdFluent":
            laws.append(f"caused {h} = {i} if {b} = {j}.")
        elif form == "cause":
            laws.append(f"a causes {h} = {i} if {b} = {j}.")
        else:
            laws.append(f"caused {h} = {i} if {b} = {j} after a.")
    if draw(st.integers(0, 3)):         # a loop of two static laws
        h, b = draw(st.permutations(names))[:2]
        i, j = draw(st.integers(0, 1)), draw(st.integers(0, 1))
        laws += [f"caused {h} = {i} if {b} = {j}.", f"caused {b} = {j} if {h} = {i}."]
    for n, k in zip(names, kinds):      # a value every step can have (else few histories at all)
        if k != "inertialFluent":
            laws.append(f"default {n} = {draw(st.integers(0, 1))}.")
    pins = [f"{n} = {draw(st.integers(0, 1))}" for n, k in zip(names, kinds)
            if k != "sdFluent" or draw(st.booleans())] or ["x = 0"]
    m = draw(st.integers(0, 2))
    decl = "; ".join(f"{n} :: {k}(v)" for n, k in zip(names, kinds))
    return (":- sorts v. :- objects 0..1 :: v.\n"
            f":- constants {decl}; a :: exogenousAction.\n" + "\n".join(laws)
            + f"\n:- query maxstep :: {m}; 0: {' & '.join(pins)}.\n")


@settings(max_examples=150, deadline=None)
@given(loops())
def test_loops_keep_the_histories_of_the_full_grounding(text):
    got = histories(text)
    assume(len(got[1]) <= MOST)
    assert got == full_histories(text), text


@settings(max_examples=60, deadline=None)
@given(descriptions())
def test_random_domains_keep_the_histories_of_the_full_grounding(drawn):
    desc, m = drawn
    text = desc.text(m, None)
    got = histories(text)
    assume(len(got[1]) <= MOST)          # about one domain in 300 has more
    assert got == full_histories(text), text
