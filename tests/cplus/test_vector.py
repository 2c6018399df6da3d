"""Grounding with arrays (cplus.ground.vector) gives exactly the rules of the closures, in the
same order, for random laws with integer arithmetic, objects and comparisons."""
from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus.errors import CPlusError
from cplus.ground import theory, vector
from cplus.load import load_text

HEAD = """:- sorts n; m; t.
:- objects {lo}..{hi} :: n; 0..3 :: m; p, q, r :: t.
:- variables X, Y :: n; Z :: m; T, U :: t.
:- constants f(t) :: inertialFluent(n); g :: simpleFluent(n); h(t) :: inertialFluent(m*); k :: sdFluent(n);
   go(t) :: exogenousAction; b :: inertialFluent.
"""

TERMS = ["X", "Y", "Z", "X + Y", "X - Z", "X * Z", "X // 2", "Y mod 3", "abs(X - Y)", "-X", "X // Z",
         "min(X, Y)", "max(X, Z) + 1", "(X + Y) // 2", "X * Y - 3"]
CONDS = ["X < Y", "X + Y =< {hi}", "(X + Y) mod 2 == 0", "T \\= U", "T @< U", "Z > 0", "X == Y",
         "abs(X) >= 1", "X \\= Z", "T == p"]


@st.composite
def laws(draw):
    lo = draw(st.integers(-4, 0))
    hi = draw(st.integers(2, 7))
    out = []
    for _ in range(draw(st.integers(1, 3))):
        head = draw(st.sampled_from(["f(T) = {e}", "g = {e}", "k = {e}", "h(U) = Z", "b", "-b", None]))
        body = draw(st.lists(st.sampled_from(["f(T) = X", "g = Y", "h(T) = Z", "h(U) = none", "go(T)",
                                              "k = X", "b"]), min_size=1, max_size=3, unique=True))
        after = draw(st.lists(st.sampled_from(["f(U) = Y", "go(U)", "g = X"]), max_size=2, unique=True))
        where = draw(st.lists(st.sampled_from(CONDS), max_size=2, unique=True))
        e = draw(st.sampled_from(TERMS))
        text = ("constraint" if head is None else "caused " + head.format(e=e)) + " if " + " & ".join(body)
        if after:
            text += " after " + " & ".join(after)
        if where:
            text += " where " + " & ".join(w.format(hi=hi) for w in where)
        out.append(text + ".")
    return HEAD.format(lo=lo, hi=hi) + "\n".join(out) + "\n"


def ground(text: str, vectorized: bool):
    prog = load_text(text)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(vector, "MIN_CELLS", 1)
        if not vectorized:
            m.setattr(theory, "ground_vectorized", lambda *a: None)
        th = theory.ground_program(prog)
    return th.rules, th.constraints, [d.render() for d in prog.diagnostics.items]


@settings(max_examples=200)
@given(laws())
def test_arrays_ground_exactly_like_the_closures(text):
    try:
        plain = ground(text, False)
    except CPlusError as exc:        # the closures refuse it (division by zero ...): so must the arrays
        with pytest.raises(CPlusError) as again:
            ground(text, True)
        assert str(again.value) == str(exc)
        return
    assert ground(text, True) == plain


def test_the_physics_law_of_spacecraft_takes_the_array_path():
    import numpy  # noqa: F401  (below 30,000 bindings the arrays are used once numpy is loaded)
    text = (":- sorts integer. :- objects -15..15 :: integer. :- variables V, V1, P :: integer.\n"
            ":- constants pos :: simpleFluent(integer); vel :: inertialFluent(integer).\n"
            "caused pos = P + ((V + V1) // 2) if vel = V1 after vel = V & pos = P\n"
            "   where (V + V1) mod 2 == 0 & P + ((V + V1) // 2) >= -15 & P + ((V + V1) // 2) =< 15.\n")
    taken = []

    def spy(*args):
        got = vector.ground_vectorized(*args)
        taken.append(got is not None)
        return got
    with pytest.MonkeyPatch.context() as m:
        m.setattr(theory, "ground_vectorized", spy)
        th = theory.ground_program(load_text(text))
    assert taken == [True]
    assert th.rules["dynamic"] == ground(text, False)[0]["dynamic"]
