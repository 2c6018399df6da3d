"""The Python API tells the truth about types: a history's Boolean values are ``bool``
wherever the history comes from, ``Domain.minimize`` is ``cplus plan --minimize``, every
JSON query says its ``kind``, and a mistyped label gets the closest one."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus import CPlusError, Domain, OptimalResult, Optimum, PlanStatus
from cplus.cli import main
from cplus.history import executed_actions, from_object, json_value, to_object
from cplus.output import history_json

ROOT = Path(__file__).resolve().parents[2]
LAMP = str(ROOT / "domains" / "examples" / "lamp.cp")
VACUUM = str(ROOT / "domains" / "examples" / "vacuum.cp")
PAYLOAD = ROOT / "domains" / "payload"

MIXED = Domain.from_text(
    ":- sorts place; arm. :- objects a, b, c :: place; r1, r2 :: arm.\n"
    ":- variables P :: place; R :: arm.\n"
    ":- constants windy :: rigid; at(arm) :: inertialFluent(place); lit :: inertialFluent; lvl :: inertialFluent(0..2);\n"
    "  go(arm) :: exogenousAction; to(arm) :: attribute(place) of go(arm);\n"
    "  mode :: exogenousAction(place*); flip :: exogenousAction.\n"
    "go(R) causes at(R)=P if to(R)=P.\nflip causes lit.\nexogenous windy.\n"
    ":- query label :: g; maxstep :: 0..2; 0: at(r1)=a & at(r2)=a & -lit; maxstep: at(r1)=c & lit.\n",
    "mixed.cp")
"""Rigid and fluent Booleans, integer-free objects, attributes and a non-Boolean action."""


def _tables(h):
    return [h.rigid, *h.states, *h.actions]


def assert_truthful(h) -> None:
    """Booleans are bool, nothing else is, and what the tables say is what value() and the
    JSON say."""
    for table in _tables(h):
        for gc, v in table.items():
            assert isinstance(v, bool) == gc.boolean, (gc.text, v)
    for t, state in enumerate(h.states):
        assert h.state_values(t) == {gc.text: json_value(gc, v) for gc, v in state.items()}
        assert all(h.value(gc.text, t) == v for gc, v in state.items() if gc.boolean)
    for t, acts in enumerate(h.actions):
        done = [gc for gc, v in acts.items() if v is True and gc.decl.kind != "attribute"]
        assert done == [gc for gc in executed_actions(acts) if gc.boolean]
        assert [e["action"] for e in history_json(h)["actions"][t]] == [gc.text for gc in
                                                                        sorted(executed_actions(acts), key=lambda g: g.id)]


def test_the_issue_s_comprehension_gives_the_actions_done():
    """``[a for a, v in h.actions[0].items() if v]`` returned every action when the values
    were the strings 'true' and 'false'."""
    d = Domain.load(LAMP)
    for h in d.solve("0", solutions=0).histories:
        assert [gc.text for gc, v in h.actions[0].items() if v] == (["flip"] if h.value("flip", 0) else [])
        assert_truthful(h)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 40))
def test_every_history_of_a_mixed_domain_is_truthful(k):
    histories = MIXED.solve("g", solutions=0).histories
    assert len(histories) > 1
    assert_truthful(histories[k % len(histories)])


def test_histories_from_every_source_are_truthful():
    """The API's solve, plans and sessions, an optimum, a proof's counterexample, and the
    worker processes of --jobs (histories travel between processes as indices)."""
    from cplus.parallel import solve_parallel
    sources = [MIXED.solve("g").histories[0], next(MIXED.plans("g")), MIXED.minimize("g", "lvl").histories[0]]
    session = MIXED.session("g")
    assert session.solve_at(2)
    sources.append(session.history())
    sources.extend(solve_parallel(MIXED, "g", solutions=0, jobs=2).histories)
    proof = Domain.from_text(":- constants p, q :: inertialFluent; a :: exogenousAction.\na causes p.\n"
                             ":- query label :: wrong; maxstep :: any; invariant: -p; 0: -p; maxstep: p.")
    cex = [c.counterexample for c in proof.prove("wrong").checks if c.counterexample is not None]
    assert cex
    for h in sources + cex:
        assert_truthful(h)


def test_to_object_and_from_object_are_inverse():
    for gc in MIXED.program.signature.ground:
        for obj in gc.domain:
            assert to_object(gc, from_object(gc, obj)) == obj
            assert isinstance(from_object(gc, obj), bool) == gc.boolean


def test_a_standing_plan_s_history_is_truthful():
    """The serving planner reads its plans from its own solver (the grounder's objects):
    its history speaks bool too, and an online plan's does."""
    from cplus.robot.online import OnlineModel
    from cplus.robot.serving import StandingModel, load_requests, serve_roles
    mailbot = Domain.load(str(ROOT / "domains" / "mailbot" / "mailbot.cp"))
    vocabulary = load_requests(str(ROOT / "domains" / "mailbot" / "requests.toml"), mailbot)
    roles = serve_roles(mailbot, vocabulary)
    fresh = OnlineModel(mailbot, "serve", roles)
    state = fresh.estimate(fresh.initial_state().state, [], ["request(1,office3)", "address(1,office1)"]).state
    for model in (fresh, StandingModel(mailbot, "serve", roles)):
        plan = model.plan(state)
        assert plan is not None and plan.length > 0
        assert_truthful(plan.history)
        assert_truthful(plan.rest().history)


# --------------------------------------------------------------------------- minimize

ROUTES = Domain.from_text(
    ":- maxAdditive :: 30.\n"
    ":- constants at :: inertialFluent(0..3); cost :: additiveFluent(0..30);\n"
    "  fly :: exogenousAction; walk :: exogenousAction.\n:- variables N :: 0..2.\n"
    "fly causes at=3. fly increments cost by 10.\n"
    "walk causes at=N+1 if at=N. nonexecutable walk if at=3. walk increments cost by 1.\n"
    "nonexecutable fly & walk.\n"
    ":- query label :: there; maxstep :: 0..5; 0: at=0 & cost=0; maxstep: at=3.\n"
    ":- query label :: never; maxstep :: 0..2; 0: at=0; maxstep: at=3 & cost<2.\n",
    "routes.cp")
"""Flying is one step for 10; walking three steps for 3."""


def _costs_by_enumeration(d: Domain, label: str, m: int) -> list[int]:
    s = d.session(label)
    return [h.value("cost", m) for h in s.histories(m)] if s.solve_at(m) else []


def test_minimize_finds_the_cheapest_plan_of_the_shortest_length_and_over_the_range():
    best = ROUTES.minimize("there", "cost")
    assert isinstance(best, OptimalResult) and isinstance(best.optimum, Optimum)
    assert (best.status, best.maxstep, best.optimum.value, best.optimum.proved) == (PlanStatus.FOUND, 1, 10, True)
    assert best.optimum.value == min(_costs_by_enumeration(ROUTES, "there", 1))
    over = ROUTES.minimize("there", "cost", over_lengths=True)
    assert (over.maxstep, over.optimum.value, over.optimum.proved, over.optimum.proved_up_to) == (3, 3, True, 5)
    assert over.optimum.value == min(c for m in range(6) for c in _costs_by_enumeration(ROUTES, "there", m))
    every = ROUTES.minimize("there", "cost", over_lengths=True, solutions=0)
    assert every.histories and {h.value("cost", h.maxstep) for h in every.histories} == {3}
    assert [h.value("walk", t) for h in over.histories for t in range(3)] == [True] * 3


def test_minimize_is_what_the_command_prints():
    """Domain.format of an optimum is cplus plan --minimize's text: the cost line once."""
    result = ROUTES.minimize("there", "cost", over_lengths=True)
    text = ROUTES.format(result)
    assert text.endswith("cost = 3 (optimal over maxstep 0..5)\n\n") and text.count("cost = 3 (") == 1
    assert ROUTES.to_json(result)["optimum"] == {"term": "cost", "value": 3, "proved": True, "lower_bound": 3,
                                                "over_lengths": True, "proved_up_to": 5, "stopped": None}
    plain = ROUTES.solve("there")
    assert "optimum" not in ROUTES.to_json(plain) and "(optimal" not in ROUTES.format(plain)


def test_the_command_prints_the_optimum_once(capsys):
    code = main(["plan", VACUUM, "--minimize", "cost"])
    out = capsys.readouterr().out
    assert code == 0 and out.count("cost = 10 (optimal)") == 1 and out.endswith("cost = 10 (optimal)\n\n")
    vacuum = Domain.load(VACUUM)
    assert out == vacuum.format(vacuum.minimize("tidy", "cost"))


def test_minimize_without_a_plan_has_no_optimum():
    none = ROUTES.minimize("never", "cost")
    assert none.status is PlanStatus.NO_PLAN and none.optimum is None and none.histories == []
    assert "optimum" in ROUTES.to_json(none) and ROUTES.to_json(none)["optimum"] is None


@pytest.mark.parametrize("call, error, message", [
    (lambda: ROUTES.minimize("there", "cst"), CPlusError, "'cst' is not a ground constant"),
    (lambda: ROUTES.minimize("there", "walk"), CPlusError, "'walk' is an action"),
    (lambda: ROUTES.minimize("there", "cost", solutions=-1), ValueError, "solutions must be a non-negative"),
    (lambda: ROUTES.minimize("there", "cost", time_limit=0), ValueError, "time_limit must be a positive"),
    (lambda: ROUTES.minimize("thre", "cost"), CPlusError, "did you mean 'there'?"),
    (lambda: Domain.from_text(":- constants c :: additiveFluent(0..3). :- maxAdditive :: 3.\n"
                              ":- query label :: q; maxstep :: 0..infinity; maxstep: c=0.").minimize(
        "q", "c", over_lengths=True), CPlusError, "give --max-horizon N"),
])
def test_minimize_refuses_bad_input_in_words(call, error, message):
    with pytest.raises(error) as info:
        call()
    assert message in str(info.value)


# --------------------------------------------------------------------------- "kind"

def test_every_json_query_says_its_kind():
    """Plain results, proofs and robot tasks' results: the query object has "kind"."""
    from cplus.robot.offline import RobotTask, refine
    lamp = Domain.load(LAMP)
    assert lamp.to_json(lamp.solve("on"))["query"]["kind"] == "query"
    proof = Domain.from_text(":- constants p :: inertialFluent; a :: exogenousAction.\na causes p.\n"
                             ":- query label :: never; maxstep :: any; invariant: -p; 0: -p; maxstep: p & -p.")
    assert proof.proof_json(proof.prove("never"))["query"]["kind"] == "query"
    task = RobotTask.load(str(PAYLOAD / "payload.cp"), str(PAYLOAD / "scene.toml"))
    refined = refine(task, "0", max_horizon=3)           # no plan that short: no refinement needed
    assert refined.to_json()["query"] == {"label": "0", "kind": "query", "min_maxstep": 0, "max_maxstep": None}


# --------------------------------------------------------------------------- labels

@pytest.mark.parametrize("typed, message", [
    ("tdy", "no query with label 'tdy' (did you mean 'tidy'? this file's labels: tidy)"),
    ("nope", "no query with label 'nope' (this file's labels: tidy)"),
])
def test_a_mistyped_label_gets_the_closest(typed, message):
    with pytest.raises(CPlusError) as info:
        Domain.load(VACUUM).query(typed)
    assert info.value.message == message


def test_a_mistyped_nmquery_label_gets_the_closest():
    d = Domain.from_text(":- constants p :: inertialFluent.\n:- nmquery label :: flipped; maxstep :: 1; 1: p.")
    with pytest.raises(CPlusError) as info:
        d.nmquery("fliped")
    assert info.value.message == ("no nmquery with label 'fliped' (did you mean 'flipped'? this file's nmquery "
                                  "labels: flipped)")


def test_the_command_and_the_shell_say_the_closest_label():
    plan = subprocess.run([sys.executable, "-m", "cplus", "plan", VACUUM, "--query", "tdy"],
                          capture_output=True, text=True, timeout=120)
    assert plan.returncode == 2 and plan.stdout == ""
    assert plan.stderr == ("cplus plan: error: --query tdy: no query with label 'tdy' (did you mean 'tidy'? "
                           "this file's labels: tidy)\n")
    shell = subprocess.run([sys.executable, "-m", "cplus", "shell", VACUUM], input="query tdy.\n",
                           capture_output=True, text=True, timeout=120)
    assert "no query with label 'tdy' (did you mean 'tidy'?" in shell.stderr


def test_a_bad_term_of_the_api_names_no_command_line_flag():
    with pytest.raises(CPlusError) as info:
        ROUTES.minimize("there", "cst")
    assert info.value.message.startswith("'cst' is not a ground constant of this domain")
