"""``cplus plan --minimize``: the optimum is checked against brute force.

Brute force is the planner's own enumeration of *every* history at a fixed maxstep
(``-n 0``, itself checked against the oracle elsewhere): the optimum must be the least cost
among them, every cheaper plan must be absent (there is none), and ``-n 0`` with
``--minimize`` must list exactly the histories of that cost.  Domains: random weighted
graphs walked by one or two agents (a sum of two costs), and the corpus's cost domains
(bw-cost, buying, mcp) with queries written here.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.cli import main
from cplus.sat.optimize import Objective, run_optimal

ADDITIVE = Path(__file__).resolve().parents[1] / "corpus" / "domains" / "examples" / "cplus" / "additive"


def run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def brute(domain: Domain, text: str, label: str, m: int, term: str):
    """Every history of the query at maxstep m, with its cost."""
    q = domain.query(label)
    fixed = type(q)(f"{label}@{m}", m, m, q.items, q.loc)
    domain.program.queries.append(fixed)
    try:
        hists = domain.solve(fixed.label, solutions=0).histories
    finally:
        domain.program.queries.remove(fixed)
    obj = Objective.parse(term, domain.program.signature)
    return [(obj.value(h), h.key()) for h in hists]


def check(domain: Domain, label: str, term: str, over_lengths: bool = False, max_horizon: int | None = None):
    q = domain.query(label)
    obj = Objective.parse(term, domain.program.signature)
    got = run_optimal(domain.theory_for(q), q, obj, solutions=0, over_lengths=over_lengths,
                      max_horizon=max_horizon)
    hi = q.hi if q.hi is not None else max_horizon
    costs = {m: brute(domain, "", label, m, term) for m in range(q.lo, hi + 1)}
    lengths = [m for m in costs if costs[m]]
    if not lengths:
        assert got.optimum is None and not got.histories
        return got
    if over_lengths:
        best = min(c for m in lengths for c, _ in costs[m])
        expected = {k for m in lengths for c, k in costs[m] if c == best}
    else:
        m = lengths[0]
        assert got.maxstep == m
        best = min(c for c, _ in costs[m])
        expected = {k for c, k in costs[m] if c == best}
    assert got.optimum.value == best and got.optimum.proved and got.optimum.lower_bound == best
    assert {h.key() for h in got.histories} == expected          # every optimal plan, nothing cheaper
    assert all(obj.value(h) == best for h in got.histories)
    return got


# ---------------------------------------------------------------------------- random weighted graphs

@st.composite
def graphs(draw):
    n = draw(st.integers(2, 4))
    edges = {}
    for a in range(n):
        for b in range(n):
            if a != b and draw(st.integers(0, 2)):
                edges[(a, b)] = draw(st.integers(0, 3))
    agents = draw(st.sampled_from([1, 2]))
    laws = [f"go(A,{b}) causes at(A)={b} if at(A)={a}." for (a, b) in edges]
    laws += [f"go(A,{b}) increments spent(A) by {c} if at(A)={a}." for (a, b), c in edges.items() if c]
    laws += [f"nonexecutable go(A,{b}) if at(A)={a}." for a in range(n) for b in range(n) if (a, b) not in edges]
    names = ["r1", "r2"][:agents]
    start = [draw(st.integers(0, n - 1)) for _ in names]
    goal = [draw(st.integers(0, n - 1)) for _ in names]
    lo = draw(st.integers(0, 1))
    hi = lo + draw(st.integers(0, 2))
    text = (f":- maxAdditive :: 9.\n:- sorts agent; node.\n:- objects {', '.join(names)} :: agent; 0..{n - 1} :: node.\n"
            ":- variables A :: agent; N, N1 :: node.\n"
            ":- constants at(agent) :: inertialFluent(node); spent(agent) :: additiveFluent(0..9);\n"
            "  go(agent, node) :: exogenousAction.\n"
            "nonexecutable go(A,N) & go(A,N1) where N @< N1.\n" +
            "\n".join(laws) +
            f"\n:- query maxstep :: {lo}..{hi};\n  0: " +
            " & ".join(f"at({r})={s} & spent({r})=0" for r, s in zip(names, start)) +
            ";\n  maxstep: " + " & ".join(f"at({r})={g}" for r, g in zip(names, goal)) + ".\n")
    term = " + ".join(f"spent({r})" for r in names)
    return text, term


@settings(max_examples=25)
@given(graphs(), st.booleans())
def test_the_optimum_is_the_cheapest_of_every_plan(case, over_lengths):
    text, term = case
    check(Domain.from_text(text), "0", term, over_lengths)


TRAP = """% a direct jump is short and dear; two hops are longer and cheap
:- maxAdditive :: 9.
:- sorts node. :- objects 0..2 :: node.
:- constants at :: inertialFluent(node); cost :: additiveFluent(0..9); jump, hop :: exogenousAction.
nonexecutable jump & hop.
jump causes at=2 if at=0.      jump increments cost by 5.    nonexecutable jump if at\\=0.
hop causes at=1 if at=0.       hop causes at=2 if at=1.      hop increments cost by 1.
nonexecutable hop if at=2.
:- query maxstep :: 0..4; 0: at=0 & cost=0; maxstep: at=2.
:- query label :: open; maxstep :: 1..infinity; 0: at=0 & cost=0; maxstep: at=2.
"""


@pytest.fixture
def trap(tmp_path):
    p = tmp_path / "trap.cp"
    p.write_text(TRAP)
    return p


def test_lexicographic_first_then_over_lengths(trap, capsys):
    code, out, _ = run(["plan", trap, "--minimize", "cost", "-q", "0"], capsys)
    assert code == 0 and out.endswith("cost = 5 (optimal)\n\n") and "ACTIONS:  jump" in out
    code, out, _ = run(["plan", trap, "--minimize", "cost", "-q", "0", "--over-lengths"], capsys)
    assert code == 0 and out.endswith("cost = 2 (optimal over maxstep 0..4)\n\n")
    assert out.count("ACTIONS:  hop") == 2
    code, out, _ = run(["plan", trap, "--minimize", "cost", "-q", "open", "--over-lengths", "--max-horizon", "3"],
                       capsys)
    assert code == 0 and out.endswith("cost = 2 (optimal over maxstep 1..3)\n\n")


def test_json_optimum(trap, capsys):
    code, out, _ = run(["plan", trap, "--minimize", "cost", "-q", "0", "--over-lengths", "--json"], capsys)
    r = json.loads(out)["results"][0]
    assert r["optimum"] == {"term": "cost", "value": 2, "proved": True, "lower_bound": 2, "over_lengths": True,
                            "proved_up_to": 4, "stopped": None}
    assert r["status"] == "found" and r["maxstep"] == 2 and len(r["histories"]) == 1


@pytest.mark.parametrize("argv, message", [
    (["--minimize", "price"], "'price' is not a ground constant"),
    (["--minimize", "jump"], "'jump' is an action"),
    (["--minimize", "at + cost + nothing"], "'nothing' is not a ground constant"),
    (["--over-lengths"], "--over-lengths applies to --minimize"),
    (["--time-limit", "1"], "--time-limit applies to --minimize"),
    (["--minimize", "cost", "--time-limit", "-1"], "must be > 0"),
    (["--minimize", "cost", "-q", "open", "--over-lengths"], "give --max-horizon N"),
])
def test_bad_minimize_options_are_one_line(trap, capsys, argv, message):
    code, out, err = run(["plan", trap, *argv], capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert out == ""


def test_a_time_limit_gives_the_best_so_far_and_exit_12(tmp_path, capsys):
    """A horizon with many plans of many costs, and a limit too short to prove the optimum:
    the plan printed is a real plan, its cost is the value printed, and the bound is below it."""
    from cplus.sat import optimize
    p = tmp_path / "trap.cp"
    p.write_text(TRAP)
    calls = []
    real = optimize.solve_until

    def slow(session, assumptions, deadline):      # the first cheaper-plan search meets the deadline
        if not assumptions:
            return real(session, assumptions, deadline)
        calls.append(deadline)
        raise optimize.Stopped
    optimize.solve_until = slow
    try:
        code, out, err = run(["plan", p, "--minimize", "cost", "-q", "0", "--over-lengths", "--time-limit", "5",
                              "--json"], capsys)
    finally:
        optimize.solve_until = real
    r = json.loads(out)["results"][0]
    assert code == 12 and calls
    assert r["optimum"]["proved"] is False and r["optimum"]["stopped"] == "time_limit"
    assert r["optimum"]["lower_bound"] == 0 and r["optimum"]["value"] == 5 and r["optimum"]["proved_up_to"] == 0
    assert r["histories"][0]["states"][-1]["cost"] == 5


def test_ctrl_c_gives_the_best_so_far(trap, capsys, monkeypatch):
    from cplus.sat import optimize
    real = optimize.improve

    def interrupted(state, strategy="linear", deadline=None):
        raise KeyboardInterrupt
    monkeypatch.setattr(optimize, "improve", interrupted)
    code, out, err = run(["plan", trap, "--minimize", "cost", "-q", "0"], capsys)
    assert code == 130 and "ACTIONS:  jump" in out
    assert "cost = 5 (not proved optimal (interrupted): lower bound 0)" in out
    monkeypatch.setattr(optimize, "improve", real)


@pytest.mark.parametrize("strategy, totalizer", [("linear", False), ("binary", False), ("linear", True),
                                                 ("binary", True)])
def test_every_strategy_agrees(trap, strategy, totalizer):
    d = Domain.load(str(trap))
    q = d.query("0")
    got = run_optimal(d.theory_for(q), q, Objective.parse("cost", d.program.signature), over_lengths=True,
                      strategy=strategy, totalizer=totalizer)
    assert got.optimum.value == 2 and got.optimum.proved


# ---------------------------------------------------------------------------- the corpus's cost domains

def test_bw_cost(tmp_path):
    p = tmp_path / "bw.cp"
    p.write_text(f":- maxAdditive :: 6.\n:- include '{ADDITIVE / 'bw-cost.cp'}'.\n"
                 ":- objects a, b, c :: block.\n"
                 ":- query maxstep :: 1..3; 0: loc(c)=b & loc(b)=a & loc(a)=table & cost=0;\n"
                 "  maxstep: loc(a)=b & loc(b)=c.\n")
    d = Domain.load(str(p))
    check(d, "0", "cost")
    check(d, "0", "cost", over_lengths=True)


def test_buying(tmp_path):
    p = tmp_path / "buy.cp"
    text = (ADDITIVE / "buying.query").read_text().replace("'buying.cp'", f"'{ADDITIVE / 'buying.cp'}'")
    p.write_text(text)
    d = Domain.load(str(p))
    got = check(d, "1", "has(seller,money)")
    assert got.optimum.value == 5            # the seller may start with nothing: 2 * 1 + 1 * 3
    check(d, "1", "has(buyer,money) + has(seller,money)")


def test_mcp(tmp_path):
    p = tmp_path / "mcp.cp"
    p.write_text(f":- maxAdditive :: 3.\n:- include '{ADDITIVE / 'mcp.cp'}'.\n"
                 ":- query maxstep :: 2..3; 0: num(mi,bank1)=3 & num(ca,bank1)=3 & num(mi,bank2)=0 & num(ca,bank2)=0;\n"
                 "  0: [/\\V | loc(V)=bank1]; maxstep: [/\\V | loc(V)=bank2].\n")
    d = Domain.load(str(p))
    check(d, "0", "num(mi,bank1) + num(ca,bank1)")
    check(d, "0", "num(ca,bank1)", over_lengths=True)


def test_a_real_time_limit_stops_the_proof(capsys):
    """bw-15's first plan (18 moves) is always waited for; a limit far shorter than the proof
    stops the search there, with the plan printed being the one whose cost is given."""
    bw15 = ADDITIVE.parents[1] / "benchmarks" / "blocks-bench-15" / "bw-15-benchmark.cp"
    code, out, err = run(["plan", bw15, "--minimize", "cost", "--time-limit", "0.001", "--json"], capsys)
    r = json.loads(out)["results"][0]
    opt = r["optimum"]
    assert code == 12, err
    assert opt["stopped"] == "time_limit" and not opt["proved"] and opt["lower_bound"] < opt["value"]
    assert r["histories"][0]["states"][-1]["cost"] == opt["value"]
