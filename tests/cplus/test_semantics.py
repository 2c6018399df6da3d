"""The meaning of C+ domains: hand-checked counts, and the SETS of histories against an oracle.

The planner (parser, grounder, completion, CNF, incremental solver, history enumeration)
must give exactly the histories that ``cplus_oracle`` computes by brute force from the
language reference, sharing none of the project's code: a catalogue of small domains, one
per law form and constant kind, and random domains that mix them all (``cplus_random``).
"""
from __future__ import annotations

import math
from contextlib import contextmanager

import pytest
from cplus_oracle import (
    FALSE,
    TRUE,
    Const,
    Description,
    Law,
    atom,
    conj,
    cst,
    first_histories,
    histories,
    neg,
    obj,
)
from cplus_random import SORTS, SUBSORTS, VARIABLES, descriptions
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.history import to_object
from cplus.sat import factor, intervals, products


def count(text: str, label: str = "0") -> tuple[int | None, int]:
    d = Domain.from_text(text)
    r = d.solve(label, solutions=0)
    return r.maxstep, len(r.histories)


def key(h) -> tuple:
    """A history as the oracle writes it: (constant text, printed value) per step."""
    def cells(table):
        return frozenset((gc.text, str(to_object(gc, v))) for gc, v in table.items())
    return cells(h.rigid), tuple(cells(s) for s in h.states), tuple(cells(a) for a in h.actions)


def planner(text: str) -> tuple[int | None, set]:
    r = Domain.from_text(text).solve(solutions=0)
    found = {key(h) for h in r.histories}
    assert len(found) == len(r.histories), "the planner printed a history twice"
    return r.maxstep, found


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
    """g(f)=2 fixes one of the three g's, whichever f names: 3 values of f x 3 x 3 others."""
    text = """
:- sorts node. :- objects 1..3 :: node. :- variables X, Y :: node.
:- constants f :: node; g(node) :: node.
exogenous f. exogenous g(X).
constraint g(f) = 2.
:- query maxstep :: 0.
"""
    assert len(Domain.from_text(text).solve(solutions=0).histories) == 3 * 9


# --------------------------------------------------------------------------- the catalogue

X, Y, Z, Q, N = (("v", v) for v in "XYZQN")
LIT, FLIP = atom("lit"), atom("flip")


def D(consts, laws, query=(), **kw) -> Description:   # noqa: N802 - reads like a declaration
    return Description(sorts=dict(SORTS), subsorts=dict(SUBSORTS), variables=dict(VARIABLES),
                       consts=list(consts), laws=list(laws), query=list(query), **kw)


F = Const("f", "inertialFluent")
G = Const("g", "inertialFluent")
FX = Const("fx", "inertialFluent", arg="s")
A = Const("a", "exogenousAction")
B = Const("b", "exogenousAction")
AX = Const("ax", "exogenousAction", arg="s")
V = Const("v", "inertialFluent", (0, 1, 2), "0..2")

CATALOGUE = {
    "simpleFluent pendulum (default after)": (D(
        [Const("s", "simpleFluent"), Const("h", "exogenousAction")],
        [Law("default", atom("s"), after=neg(atom("s"))), Law("default", neg(atom("s")), after=atom("s")),
         Law("causes", atom("s"), action=atom("h"), cond=atom("s")),
         Law("causes", neg(atom("s")), action=atom("h"), cond=neg(atom("s")))]), 2),
    "simpleFluent with inertial law": (D(
        [Const("s", "simpleFluent"), A], [Law("inertial", cst("s")), Law("causes", atom("s"), action=atom("a"))]), 2),
    "sdFluent: static caused and default": (D(
        [F, Const("q", "sdFluent"), A],
        [Law("caused", atom("q"), cond=atom("f")), Law("default", neg(atom("q"))),
         Law("causes", atom("f"), action=atom("a"))]), 1),
    "sdFluent in a dynamic body, may cause": (D(
        [F, G, Const("q", "sdFluent"), A],
        [Law("caused", atom("q"), cond=("or", atom("f"), atom("g"))), Law("default", neg(atom("q"))),
         Law("may_cause", atom("g"), action=atom("a"), cond=atom("q"))]), 2),
    "multi-valued inertial fluent, arithmetic head and where": (D(
        [V, A],
        [Law("caused", ("eq", cst("v"), ("+", N, obj(1))), after=conj(("eq", cst("v"), N), atom("a")),
             where=("cmp", "<", N, obj(2)))]), 2),
    "out-of-domain head value acts as caused false (C.7)": (D(
        [V, A],
        [Law("caused", ("eq", cst("v"), ("+", N, obj(1))), after=conj(("eq", cst("v"), N), atom("a")))]), 2),
    "symbolic values with none (star sort), nested constant f(loc)": (D(
        [Const("loc", "inertialFluent", ("k1", "k2", "none"), "s*"), Const("seen", "sdFluent", arg="s"),
         Const("go", "exogenousAction", arg="s")],
        [Law("causes", ("eq", cst("loc"), X), action=atom("go", X)),
         Law("nonexecutable", action=conj(atom("go", X), atom("go", Y)), where=("cmp", "@<", X, Y)),
         Law("caused", atom("seen", X), cond=("eq", cst("loc"), X)), Law("default", neg(atom("seen", X))),
         Law("constraint", ("or", ("eq", cst("loc"), obj("none")), ("eq", cst("seen", cst("loc")), obj("true"))))],
        [(0, ("eq", cst("loc"), obj("none")))]), 2),
    "additive fluent: increments, decrements, sum out of domain": (D(
        [Const("n", "additiveFluent", (0, 1, 2, 3), "0..3"), A, B, Const("c", "exogenousAction")],
        [Law("increments", cst("n"), action=atom("a"), amount=2), Law("decrements", cst("n"), action=atom("b"),
                                                                         amount=1),
         Law("increments", cst("n"), action=atom("c"), amount=1, cond=atom("a"))],
        [(0, ("eq", cst("n"), obj(1)))], max_additive=2), 1),
    "additive: a contribution beyond maxAdditive is impossible, conflicting amounts": (D(
        [Const("n", "additiveFluent", (0, 1, 2, 3, 4), "0..4"), A, B],
        [Law("increments", cst("n"), action=atom("a"), amount=3),
         Law("increments", cst("n"), action=atom("b"), amount=1),
         Law("increments", cst("n"), action=atom("b"), amount=2, cond=atom("a"))],
        [(0, ("eq", cst("n"), obj(0)))], max_additive=2), 1),
    "additive action summing two actions' contributions": (D(
        [Const("cost", "additiveAction", (0, 1, 2, 3), "0..3"), AX, F],
        [Law("increments", cst("cost"), action=atom("ax", X), amount=2, where=("cmp", "=", X, obj("k1"))),
         Law("increments", cst("cost"), action=atom("ax", X), amount=1, where=("cmp", "=", X, obj("k2"))),
         Law("causes", atom("f"), action=("eq", cst("cost"), obj(3)))],
        max_additive=3), 1),
    "rigid constants: c :: D, rigid(D) with default and rigid laws": (D(
        [Const("r", "rigid", (0, 1), "0..1"), Const("rb", "rigid"), F, A],
        [Law("exogenous", cst("r")), Law("default", neg(atom("rb"))), Law("caused", atom("rb"), cond=("eq", cst("r"), obj(1))),
         Law("causes", atom("f"), action=atom("a"), cond=atom("rb"))]), 1),
    "rigid fact and rigid constraint": (D(
        [Const("r", "rigid", (0, 1), "0..1"), Const("rb", "rigid"), F],
        [Law("exogenous", cst("r")), Law("fact", atom("rb")),
         Law("constraint", ("imp", atom("rb"), ("eq", cst("r"), obj(1))))]), 0),
    "plain action: default and caused": (D(
        [F, Const("act", "action"), A],
        [Law("default", neg(atom("act"))), Law("caused", atom("act"), cond=conj(atom("a"), atom("f"))),
         Law("causes", neg(atom("f")), action=atom("act"))]), 2),
    "action head of causes": (D(
        [F, A, Const("act", "action")],
        [Law("default", neg(atom("act"))), Law("causes", atom("act"), action=atom("a")),
         Law("causes", atom("f"), action=atom("act"))]), 1),
    "non-Boolean exogenous action": (D(
        [V, Const("e", "exogenousAction", (0, 1), "0..1")],
        [Law("caused", ("eq", cst("v"), obj(1)), after=("eq", cst("e"), obj(1)))]), 1),
    "attribute of a parameterised action": (D(
        [FX, AX, Const("amt", "attribute", (1, 2), "1..2", arg="s", parent="ax")],
        [Law("causes", atom("fx", X), action=atom("ax", X), cond=("eq", cst("amt", X), obj(2)))],
        [(0, neg(atom("fx", obj("k1"))))]), 1),
    "declared abAction caused by a law, unless": (D(
        [F, A, B, Const("ab", "abAction")],
        [Law("causes", atom("f"), action=atom("a"), unless=cst("ab")), Law("caused", atom("ab"), cond=atom("b"))]), 1),
    "unless in a dynamic law: auto abAction with an argument": (D(
        [FX, AX, B],
        [Law("causes", atom("fx", X), action=atom("ax", X), unless=cst("ab1", X)),
         Law("caused", atom("ab1", X), cond=conj(atom("b"), atom("fx", X)))]), 1),
    "unless in a static law: auto abnormality fluent": (D(
        [F, G, Const("q", "sdFluent")],
        [Law("caused", atom("q"), cond=atom("f"), unless=cst("ab2")), Law("default", neg(atom("q"))),
         Law("caused", atom("ab2"), cond=atom("g"))]), 0),
    "unless in a rigid law: auto rigid abnormality": (D(
        [Const("rb", "rigid"), Const("rc", "rigid"), F],
        [Law("exogenous", cst("rc")), Law("default", atom("rb")),
         Law("caused", neg(atom("rb")), cond=atom("rc"), unless=cst("ab3"))]), 0),
    "unless in an action law and in increments": (D(
        [Const("n", "additiveFluent", (0, 1, 2), "0..2"), A, B, Const("act", "action")],
        [Law("default", neg(atom("act"))), Law("caused", atom("act"), cond=atom("a"), unless=cst("ab4")),
         Law("increments", cst("n"), action=atom("a"), amount=1, unless=cst("ab5")),
         Law("caused", atom("ab5"), cond=atom("b"))],
        [(0, ("eq", cst("n"), obj(0)))], max_additive=2), 1),
    "noconcurrency: Boolean actions only, attributes and non-Boolean exempt": (D(
        [F, A, B, Const("amt", "attribute", (1, 2), "1..2", parent="a"),
         Const("e", "exogenousAction", (0, 1), "0..1")],
        [], [(0, atom("f"))], noconcurrency=True), 1),
    "nonexecutable and always": (D(
        [F, A, B],
        [Law("nonexecutable", action=atom("a"), cond=atom("f")), Law("always", ("imp", atom("b"), atom("a"))),
         Law("causes", atom("f"), action=atom("a"))]), 2),
    "constraint, constraint after, fact": (D(
        [F, G, Const("q", "sdFluent"), A],
        [Law("constraint", ("or", atom("f"), atom("g"))), Law("constraint", atom("g"), after=atom("a")),
         Law("fact", neg(atom("q"))), Law("causes", neg(atom("f")), action=atom("a"))]), 2),
    "never and impossible (Cplus2ASP), also with after": (D(
        [F, G, A],
        [Law("never", conj(atom("f"), atom("g"))), Law("impossible", neg(atom("f")), after=atom("a"))]), 1),
    "rigid law on a fluent, possibly caused": (D(
        [Const("s", "simpleFluent"), A],
        [Law("rigid", cst("s")), Law("possibly", atom("s"), after=atom("s")),
         Law("possibly", neg(atom("s")), after=conj(neg(atom("s")), neg(atom("a"))))]), 2),
    "exogenous with a condition": (D(
        [F, Const("act", "action")],
        [Law("exogenous", cst("act"), cond=atom("f")), Law("default", neg(atom("act"))),
         Law("causes", neg(atom("f")), action=atom("act"))]), 2),
    "quantifiers, subsorts and where": (D(
        [FX, AX, Const("all_on", "sdFluent")],
        [Law("caused", atom("all_on"), cond=("q", "all", "Q", atom("fx", Q))), Law("default", neg(atom("all_on"))),
         Law("causes", atom("fx", Z), action=atom("ax", Z)),
         Law("nonexecutable", action=conj(atom("ax", X), atom("ax", Y)), where=("cmp", "\\=", X, Y))],
        [(0, ("q", "ex", "Q", neg(atom("fx", Q))))]), 1),
    "comparisons and arithmetic between constants": (D(
        [V, Const("w", "inertialFluent", (0, 1, 2), "0..2"), A],
        [Law("constraint", ("cmp", "=<", cst("v"), cst("w"))),
         Law("caused", ("eq", cst("w"), obj(2)), after=conj(atom("a"), ("cmp", "=", ("+", cst("v"), obj(1)),
                                                                        cst("w"))))]), 1),
    # G of `inertial c if G` is read at the state before (and the actions done): an action
    # that turns G off does not free c at that step
    "inertial c if G: G before the step": (D(
        [Const("s", "simpleFluent"), G, A],
        [Law("inertial", cst("s"), cond=atom("g")), Law("causes", neg(atom("g")), action=atom("a"))]), 2),
    "inertial c if G, G over the action, multi-valued c": (D(
        [Const("w", "simpleFluent", (0, 1, 2), "0..2"), A, B],
        [Law("inertial", cst("w"), cond=neg(atom("a"))), Law("causes", ("eq", cst("w"), obj(0)), action=atom("a")),
         Law("causes", ("eq", cst("w"), obj(2)), action=atom("b"))]), 2),
    "exogenous c if G on a fluent and on an action, F if G": (D(
        [Const("q", "sdFluent"), F, Const("act", "action")],
        [Law("exogenous", cst("q"), cond=atom("f")), Law("fact", neg(atom("q")), cond=neg(atom("f"))),
         Law("exogenous", cst("act"), cond=atom("f")), Law("default", neg(atom("act"))),
         Law("causes", neg(atom("f")), action=atom("act"))]), 2),
    "conjunctive heads, caused false, caused true": (D(
        [Const("q", "sdFluent"), Const("r", "sdFluent"), F, G, A],
        [Law("caused", conj(atom("q"), neg(atom("r"))), cond=atom("f")), Law("default", neg(atom("q"))),
         Law("default", atom("r")), Law("caused", FALSE, cond=conj(atom("q"), neg(atom("f")))),
         Law("caused", TRUE, cond=atom("q")),
         Law("caused", conj(atom("f"), neg(atom("g"))), after=atom("a"))]), 2),
    "strong noconcurrency counts a non-Boolean action that is not none": (D(
        [F, A, Const("go", "exogenousAction", ("k1", "k2", "none"), "s*"), Const("e", "exogenousAction", (0, 1), "0..1")],
        [], [(0, atom("f"))], noconcurrency=True, strong=True), 1),
    "query: action items, maxstep items, connectives": (D(
        [F, G, A, B],
        [Law("causes", atom("f"), action=atom("a")), Law("causes", ("eq", cst("g"), obj("false")), action=atom("b"))],
        [(0, neg(atom("a"))), (1, ("iff", atom("b"), atom("a"))), ("maxstep", ("imp", atom("g"), atom("f"))),
         (0, ("or", TRUE, FALSE))]), 2),
}


@pytest.mark.parametrize("name", CATALOGUE)
def test_catalogue_agrees_with_the_oracle(name):
    """One domain per law form and constant kind: the same non-empty set of histories."""
    desc, m = CATALOGUE[name]
    expected = histories(desc, m)
    assert expected, "a catalogue entry must have histories, or it shows nothing"
    assert planner(desc.text(m)) == (m, expected), desc.text(m)


def test_histories_are_distinct_even_with_auxiliary_variables():
    """A disjunctive body gets a Tseitin variable; each history still comes once."""
    desc = D([F, G, Const("r", "sdFluent"), A],
             [Law("caused", atom("r"), cond=("or", atom("f"), atom("g"))), Law("default", neg(atom("r"))),
              Law("causes", atom("f"), action=atom("a"))])
    assert planner(desc.text(1)) == (1, histories(desc, 1))


# --------------------------------------------------------------------------- random domains


@settings(max_examples=200)
@given(descriptions(), st.booleans())
def test_planner_agrees_with_the_oracle_on_random_domains(drawn, ranged):
    """Exactly the oracle's histories, at the first maxstep of the range that has one."""
    desc, m = drawn
    lo = 0 if ranged else m
    text = desc.text(m, lo if ranged else None)
    expected = first_histories(desc, lo, m)
    assume(len(expected[1]) <= 600)      # bounds the run time; about 1 domain in 250 is larger
    assert planner(text) == expected, text


# the encodings that apply only where they pay, applied wherever they can (the random
# domains are too small for them to pay)
THRESHOLDS = {factor: {"_FROM": 0, "_GAIN": math.inf},
              products: {"MIN_ROWS": 0, "GAIN": math.inf},
              intervals: {"MIN_ROWS": 0, "GAIN": math.inf}}


@contextmanager
def forced(module):
    """Within the block, ``module``'s encoding is used wherever it can be, whatever it costs."""
    with pytest.MonkeyPatch.context() as patch:
        for name, value in THRESHOLDS[module].items():
            patch.setattr(module, name, value)
        yield


@pytest.mark.parametrize("module", THRESHOLDS, ids=lambda m: m.__name__)
@settings(max_examples=80, deadline=None)
@given(drawn=descriptions())
def test_planner_agrees_with_the_oracle_when_an_encoding_is_forced(module, drawn):
    desc, m = drawn
    expected = first_histories(desc, m, m)
    assume(len(expected[1]) <= 600)
    with forced(module):
        assert planner(desc.text(m, None)) == expected
