"""``maxstep :: any`` with ``invariant: F``: the three checks, their words, JSON and exit codes.

The proof is checked against search: on random small domains (three Boolean fluents, so
eight states and every reachable goal within seven steps) a query the invariant "proves"
unanswerable never has a plan of length 0..8, and every counterexample of a wrong invariant
is a real state or transition that breaks the check it is reported for.
"""
from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.cli import main
from cplus.invariant import InvariantStatus

TWO_LAMPS = """% a switch toggles both lamps: they never differ
:- constants a, b :: inertialFluent; flip :: exogenousAction.
flip causes a if -a.
flip causes -a if a.
flip causes b if -b.
flip causes -b if b.
:- query label :: proof; maxstep :: any; invariant: a <->> b; 0: -a & -b; maxstep: a & -b.
:- query label :: wrong; maxstep :: any; invariant: -a; 0: -a & -b; maxstep: a & -b.
:- query label :: init; maxstep :: any; invariant: a <->> b; 0: -a; maxstep: a & -b.
:- query label :: goal; maxstep :: any; invariant: a ++ -a; 0: -a & -b; maxstep: a & -b.
:- query label :: empty; maxstep :: any; invariant: a <->> b; 0: a & -a; maxstep: a & -b.
"""


@pytest.fixture
def lamps(tmp_path):
    p = tmp_path / "lamps.cp"
    p.write_text(TWO_LAMPS)
    return str(p)


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_a_proof_prints_each_check_and_exits_10(lamps, capsys):
    code, out, err = run(["plan", lamps, "-q", "proof"], capsys)
    assert code == 10, err
    assert out == ("% Verifying that the invariant holds in every initial state... done.\n"
                   "% Verifying that no state satisfying the invariant satisfies the goal... done.\n"
                   "% Verifying that every transition preserves the invariant... done.\n"
                   "\nNo solution for any maxstep.\n\n")


@pytest.mark.parametrize("label, failed, text", [
    ("init", "init", "The invariant does not hold in this initial state:"),
    ("goal", "goal", "This state satisfies the invariant and the goal:"),
    ("wrong", "transition", "This transition does not preserve the invariant:"),
])
def test_a_failed_check_prints_its_counterexample_and_exits_11(lamps, capsys, label, failed, text):
    code, out, _ = run(["plan", lamps, "-q", label], capsys)
    assert code == 11
    assert text in out and out.rstrip().endswith("is wrong.")
    assert out.count("... failed.") == 1
    code, out, _ = run(["plan", lamps, "-q", label, "--json"], capsys)
    doc = json.loads(out)["results"][0]
    assert doc["status"] == "invariant_wrong" and doc["histories"] == []
    assert doc["invariant"]["failed"] == failed
    assert [c["check"] for c in doc["invariant"]["checks"]][-1] == failed
    cex = doc["invariant"]["counterexample"]
    assert cex["maxstep"] == (1 if failed == "transition" else 0)


def test_the_transition_counterexample_breaks_the_invariant(lamps):
    proof = Domain.load(lamps).prove("wrong")
    cex = proof.failed.counterexample
    assert proof.failed.name == "transition"
    assert cex.value("a", 0) is False and cex.value("a", 1) is True    # -a, then a
    assert cex.value("flip", 0) is True


def test_no_initial_state_is_said(lamps, capsys):
    code, out, _ = run(["plan", lamps, "-q", "empty"], capsys)
    assert code == 10
    assert "% No state satisfies the query's conditions at step 0." in out


def test_json_of_a_proof(lamps, capsys):
    code, out, _ = run(["plan", lamps, "-q", "proof", "--json"], capsys)
    doc = json.loads(out)
    r = doc["results"][0]
    assert doc["format"] == "cplus.plan/1" and code == 10
    assert r["status"] == "no_plan_proved" and r["query"]["max_maxstep"] == "any"
    assert r["invariant"]["formula"] == "a <->> b" and r["invariant"]["failed"] is None
    assert [c["check"] for c in r["invariant"]["checks"]] == ["init", "goal", "transition"]
    assert all(c["holds"] for c in r["invariant"]["checks"])


def test_the_init_check_is_every_initial_state_not_some(tmp_path, capsys):
    """The literal reading of CCALC's init check (``I & 0: F`` satisfiable) would pass here
    and "prove" a goal unreachable that holds at maxstep 0 when p starts true."""
    p = tmp_path / "d.cp"
    p.write_text(":- constants p :: inertialFluent.\n"
                 ":- query label :: 1; maxstep :: any; invariant: -p; maxstep: p.\n"
                 ":- query label :: 2; maxstep :: 0; maxstep: p.\n")
    code, out, _ = run(["plan", str(p), "-q", "1"], capsys)
    assert code == 11 and "The invariant does not hold in this initial state:" in out
    assert run(["plan", str(p), "-q", "2"], capsys)[0] == 0


@pytest.mark.parametrize("query, message, at", [
    ("maxstep :: any; maxstep: a", "'maxstep :: any' needs an 'invariant: F' item", "maxstep :: any"),
    ("maxstep :: 0..3; invariant: a; maxstep: b", "an invariant belongs to a query with 'maxstep :: any'", "a; max"),
    ("maxstep :: any; invariant: a; 0: a", "the query needs a goal", "query maxstep"),
    ("maxstep :: any; invariant: a; 1: a; maxstep: b", "step 0 or of maxstep only", "1: a"),
    ("maxstep :: any; invariant: a; 0: flip; maxstep: b", "'flip' is an action", "flip;"),
    ("maxstep :: any; invariant: 0: a; maxstep: b", "without time stamps", "0: a"),
    ("maxstep :: any; invariant: a; (0: a) ->> (maxstep: b)", "not both", "(0: a) ->>"),
    ("maxstep :: any; invariant: a; invariant: b; maxstep: b", "at most one invariant", "invariant: b"),
])
def test_malformed_proof_queries_are_located_errors(tmp_path, capsys, query, message, at):
    p = tmp_path / "d.cp"
    head = ":- constants a, b :: inertialFluent; flip :: exogenousAction.\n"
    p.write_text(head + f":- query {query}.\n")
    code, _, err = run(["plan", str(p)], capsys)
    assert code == 2 and message in err, err
    col = (head + ":- query " + query).index(at) - len(head) + 1
    assert f"{p}:2:{col}: error:" in err, err


def test_a_proof_query_is_not_searched_through_the_api(lamps):
    from cplus.errors import QueryError
    with pytest.raises(QueryError, match="maxstep :: any"):
        Domain.load(lamps).solve("proof")


def test_any_and_invariant_stay_names_elsewhere(tmp_path, capsys):
    """CCALC's query words are not reserved: a macro named ``any`` is a maxstep."""
    p = tmp_path / "d.cp"
    p.write_text(":- macros any -> 1.\n:- constants invariant :: inertialFluent; f :: exogenousAction.\n"
                 "f causes invariant.\n:- query maxstep :: any; 0: -invariant; maxstep: invariant.\n")
    code, out, _ = run(["plan", str(p)], capsys)
    assert code == 0 and "1:  invariant" in out


# ---------------------------------------------------------------------------- against search

FLUENTS = ("p", "q", "r")


class F:
    """A random formula: its C+ text and its truth in a state (a dict of fluent values)."""

    def __init__(self, text: str, holds) -> None:
        self.text, self.holds = text, holds

    def __neg__(self) -> F:
        return F(f"-({self.text})", lambda s: not self.holds(s))


OPS = {"&": lambda x, y: x and y, "++": lambda x, y: x or y, "->>": lambda x, y: (not x) or y,
       "<->>": lambda x, y: x == y}


@st.composite
def literal(draw):
    f = draw(st.sampled_from(FLUENTS))
    if draw(st.booleans()):
        return F(f, lambda s: bool(s[f]))
    return F(f"-{f}", lambda s: not s[f])


@st.composite
def formula(draw, depth=2):
    if depth == 0 or draw(st.integers(0, 2)) == 0:
        return draw(literal())
    op = draw(st.sampled_from(sorted(OPS)))
    x, y = draw(formula(depth - 1)), draw(formula(depth - 1))
    return F(f"({x.text} {op} {y.text})", lambda s: OPS[op](x.holds(s), y.holds(s)))


@st.composite
def domains(draw):
    laws = []
    for act in ("a1", "a2"):
        for _ in range(draw(st.integers(1, 2))):
            laws.append(f"{act} causes {draw(literal()).text} if {draw(formula(1)).text}.")
        if draw(st.booleans()):
            laws.append(f"nonexecutable {act} if {draw(formula(1)).text}.")
    if draw(st.booleans()):
        laws.append(f"constraint {draw(formula(1)).text}.")
    init = draw(formula(1))
    goal = draw(formula(1))
    either = F(f"({init.text} ++ {(-goal).text})", lambda s: init.holds(s) or not goal.holds(s))
    inv = draw(st.sampled_from([draw(formula(2)), -goal, either]))
    text = (":- constants p, q, r :: inertialFluent; a1, a2 :: exogenousAction.\n" + "\n".join(laws) +
            f"\n:- query label :: proof; maxstep :: any; invariant: {inv.text}; 0: {init.text}; "
            f"maxstep: {goal.text}.\n"
            f":- query label :: search; maxstep :: 0..8; 0: {init.text}; maxstep: {goal.text}.\n")
    return text, init, goal, inv


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(domains())
def test_a_proof_is_never_contradicted_by_a_plan(case):
    text, init, goal, inv = case
    d = Domain.from_text(text)
    proof = d.prove("proof")
    planned = d.solve("search")
    if proof.status is InvariantStatus.NO_PLAN_PROVED:
        assert planned.status.name == "NO_PLAN", text     # 8 states: a plan would be this short
        return
    cex = proof.failed.counterexample
    states = [cex.state_values(t) for t in range(cex.maxstep + 1)]
    if proof.failed.name == "init":
        assert init.holds(states[0]) and not inv.holds(states[0])
    elif proof.failed.name == "goal":
        assert inv.holds(states[0]) and goal.holds(states[0])
    else:
        assert inv.holds(states[0]) and not inv.holds(states[1])
