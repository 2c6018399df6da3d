"""Integer arithmetic compiled to one function (cplus.ground.intexpr) gives what the general
closures give, for every term and comparison over variables that hold integers or objects."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from cplus import ir
from cplus.errors import GroundingError
from cplus.ground import compile as compiled
from cplus.ground import intexpr

LOC = None
NAMES = ("P", "S", "D")
values = st.one_of(st.integers(-50, 50), st.sampled_from(["a", "b"]))


def terms():
    leaf = st.one_of(st.sampled_from(NAMES).map(lambda n: ir.Var(n, None, LOC)),
                     st.one_of(st.integers(-9, 9), st.just("a")).map(lambda v: ir.Lit(v)))
    return st.recursive(leaf, lambda sub: st.one_of(
        st.tuples(st.sampled_from(["+", "-", "*", "//", "mod"]), sub, sub).map(lambda x: ir.Arith(x[0], x[1:], LOC)),
        sub.map(lambda a: ir.Arith("neg", (a,), LOC))), max_leaves=6)


def both(make):
    """(compiled as one function, the general closure) of the same node."""
    fast = make()
    old = compiled.int_term, compiled.int_comparison
    compiled.int_term = compiled.int_comparison = lambda node, general: general
    try:
        general = make()
    finally:
        compiled.int_term, compiled.int_comparison = old
    return fast, general


def outcome(fn, env):
    try:
        return fn(env, 0)
    except GroundingError as exc:
        return str(exc)


@settings(max_examples=300, deadline=None)
@given(terms(), st.fixed_dictionaries({n: values for n in NAMES}))
def test_terms_are_computed_as_the_closures_compute_them(t, env):
    fast, general = both(lambda: compiled.compile_term(t, None))  # type: ignore[arg-type]
    assert outcome(fast, env) == outcome(general, env)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(["<", ">", "=<", ">=", "=", "==", "\\=="]), terms(), terms(),
       st.fixed_dictionaries({n: values for n in NAMES}))
def test_comparisons_are_decided_as_the_closures_decide_them(op, left, right, env):
    f = ir.Cmp(op, left, right, LOC)
    fast, general = both(lambda: compiled.compile_formula(f, None))  # type: ignore[arg-type]
    assert outcome(fast, env) == outcome(general, env)


def test_plain_integer_arithmetic_is_one_function():
    p, s, d = (ir.Var(n, None, LOC) for n in NAMES)
    where = ir.Cmp("=<", ir.Arith("+", (p, ir.Arith("*", (s, d), LOC)), LOC), ir.Lit(300), LOC)
    fn = intexpr.int_comparison(where, lambda env, time: "general")
    assert fn({"P": 120, "S": 15, "D": 12}, 0) is True
    assert fn({"P": 121, "S": 15, "D": 12}, 0) is False
    assert fn({"P": "a", "S": 15, "D": 12}, 0) == "general"
    division = ir.Arith("//", (p, s), LOC)
    general = lambda env, time: None  # noqa: E731
    assert intexpr.int_term(division, general) is general
