"""CCALC's text output: layout, attributes inside actions, show/hide, atom order."""
from __future__ import annotations

from pathlib import Path

import pytest

from cplus import Domain

ROOT = Path(__file__).resolve().parents[2]


def text(src: str, **kw) -> str:
    d = Domain.from_text(src)
    return d.format(d.solve(**kw))


def test_attributes_are_printed_inside_their_action():
    out = text(""":- sorts jet; axis. :- objects j1 :: jet; x, y :: axis.
:- constants fire(jet) :: exogenousAction; force(jet,axis) :: attribute(-2..2) of fire(jet);
  on :: inertialFluent.
:- query maxstep :: 1; 0: -on & fire(j1) & force(j1,x) = -1 & force(j1,y) = 2; 1: -on.""")
    assert "ACTIONS:  fire(j1,force(x)= -1,force(y)=2)" in out


def test_rigid_atoms_come_first_without_a_label():
    out = text(":- constants w :: rigid(1..3); p :: inertialFluent. w=2. :- query maxstep :: 0; 0: p.")
    assert out == "\nw=2\n\n0:  p\n\n\n"


BASE = """:- sorts loc. :- objects l1, l2 :: loc. :- variables L :: loc.
:- constants at :: inertialFluent(loc); moved :: inertialFluent; go(loc) :: exogenousAction.
go(L) causes at=L. go(L) causes moved. nonexecutable go(L) if at=L.
"""
QUERY = ":- query maxstep :: 1; 0: at=l1 & -moved; 1: at=l2."


@pytest.mark.parametrize("display, state1, actions", [
    ("", "1:  moved  at=l2", "ACTIONS:  go(l2)"),   # boolean sorts before loc
    (":- hide moved.", "1:  at=l2", "ACTIONS:  go(l2)"),
    # CCALC 2 (in_show_list): a show spec without `positive` or `all` shows only what it names,
    # actions included, so a spec naming no action prints no ACTIONS line
    (":- show at=L.", "1:  at=l2", None),
    (":- hide all. :- show moved.", "1:  moved", None),           # hide all: only what is shown
    (":- hide all. :- show go(L); at=l2.", "1:  at=l2", "ACTIONS:  go(l2)"),
    (":- show at=L; moved; go(L). :- hide at=l2.", "1:  moved", "ACTIONS:  go(l2)"),  # hide wins
    (":- show positive.", "1:  moved  at=l2", "ACTIONS:  go(l2)"),  # the default, said
    (":- show negative.", "0:  -moved", None),                    # false Boolean atoms only
    (":- show all.", "0:  at=l1  -moved", "ACTIONS:  go(l2)"),    # positive and negative literals
    (":- show none.", "1:", None),
    (":- show at; go.", "1:  at=l2", "ACTIONS:  go(l2)"),         # a constant without its arguments
    (":- show positive; -moved.", "0:  at=l1  -moved", "ACTIONS:  go(l2)"),
    (":- show moved. :- show go(L).", "1:  moved", "ACTIONS:  go(l2)"),  # show statements add up
])
def test_show_and_hide(display, state1, actions):
    out = text(BASE + display + "\n" + QUERY)
    lines = [x for x in out.splitlines() if x]
    assert state1 in lines
    assert (actions in lines) if actions else not any(x.startswith("ACTIONS") for x in lines)


def test_atom_order_follows_ccalc():
    """Simple fluents before sdFluents; by value sort name; plain before inertial; then
    declaration order; arguments in object declaration order."""
    out = text(""":- sorts b; a. :- objects z, y :: b; q :: a.
:- constants s(b) :: sdFluent; k :: inertialFluent(a); m :: simpleFluent(a); n :: inertialFluent(b);
  p(b) :: inertialFluent.
:- variables X :: b. exogenous m. caused s(X) if p(X). default -s(X).
:- query maxstep :: 0; 0: k=q & m=q & n=z & p(z) & p(y).""")
    assert out.splitlines()[1] == "0:  m=q  k=q  n=z  p(z)  p(y)  s(z)  s(y)"


@pytest.mark.parametrize("name, label, length, count", [
    ("lamp.cp", "0", 1, 3), ("lamp.cp", "on", 1, 1), ("pendulum.cp", "0", 2, 4), ("blocks.cp", "0", 3, None),
])
def test_the_example_domains(name, label, length, count):
    d = Domain.load(str(ROOT / "domains" / "examples" / name))
    r = d.solve(label, solutions=0 if count else 1)
    assert r.maxstep == length
    if count:
        assert len(r.histories) == count


def test_values_none_are_never_shown_by_default():
    """CCALC prints no `c=none` for a fluent (`positive` leaves it out, `negative` shows it);
    a non-Boolean action's `none` is its value and is printed."""
    src = """:- sorts loc. :- objects l1 :: loc.
:- constants target :: inertialFluent(loc*); pick :: exogenousAction(loc*).
%s
:- query maxstep :: 1; 0: target=none & pick=none."""
    out = text(src % "")
    assert "target=none" not in out and "0:" in out.splitlines()[1]
    assert "ACTIONS:  pick=none" in out
    assert "0:  target=none" in text(src % ":- show negative.")


def test_abnormalities_are_shown_by_ab_or_all():
    """An abnormality action of an `unless` clause is shown only by `ab`, `all` or a pattern."""
    src = """:- constants p :: inertialFluent; a :: exogenousAction.
a causes p unless broken.
caused broken if a.
%s
:- query maxstep :: 1; 0: a."""
    assert "broken" not in text(src % "")
    assert "ACTIONS:  a  broken" in text(src % ":- show positive; ab.")
    assert "ACTIONS:  broken" in text(src % ":- show ab.")
    assert "ACTIONS:  a  broken" in text(src % ":- show all.")


def test_a_constant_named_like_a_keyword_is_the_keyword_with_a_warning():
    d = Domain.from_text(":- constants negative :: simpleFluent. :- show negative. :- query maxstep :: 0; 0: negative.")
    assert any("ambiguous" in w.message for w in d.diagnostics.items)
    assert d.format(d.solve()).strip() == "0:"
