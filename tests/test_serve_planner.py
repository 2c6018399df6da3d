"""The standing-goal planner (cplus.robot.serving.standing): one solver per run, the shortest plan
within a conflict budget (the same length as a fresh search finds), the oldest goal first
beyond it, partial plans followed by a re-plan in the loop, one grounding per run."""
from __future__ import annotations

import doctest
import random
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cplus.robot.serving.standing
import cplus.robot.serving.vocabulary
from cplus.api import Domain
from cplus.robot.online.estimation import OnlineModel, State
from cplus.robot.online.executors import SimulatedExecutor
from cplus.robot.online.loop import OnlineLoop, OnlineStatus
from cplus.robot.serving.goals import GoalBoard
from cplus.robot.serving.reactive import serve_roles
from cplus.robot.serving.standing import GoalLiteral, StandingModel
from cplus.robot.serving.vocabulary import load_requests
from nxt_link.wire.clock import VirtualClock

MAILBOT = Path(__file__).resolve().parent.parent / "domains" / "mailbot"
OFFICES = [f"office{i}" for i in range(1, 5)]


@pytest.mark.parametrize("module", [cplus.robot.serving.standing, cplus.robot.serving.vocabulary])
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0


@pytest.fixture(scope="module")
def mailbot():
    d = Domain.load(str(MAILBOT / "mailbot.cp"))
    v = load_requests(str(MAILBOT / "requests.toml"), d)
    roles = serve_roles(d, v)
    fresh = OnlineModel(d, "serve", roles)
    standing = StandingModel(d, "serve", roles, budget=None)
    return d, v, fresh, standing


def state_after(model: OnlineModel, requests: list[tuple[str, str]], moves: list[str]) -> State:
    """The state after some requests (slots 1, 2, ...) and then some of the robot's actions
    (those that are possible; the others are skipped)."""
    s = model.initial_state().state
    events = [e for i, (a, b) in enumerate(requests, 1) for e in (f"request({i},{a})", f"address({i},{b})")]
    s = model.estimate(s, [], events).state
    for text in moves:
        act = next(a for a in model.acts({model.by_text[text]: "true"}))
        est = model.estimate(s, [act])
        if est.unique:
            s = est.state
    return s


office = st.sampled_from(OFFICES)
action = st.sampled_from([f"move({o})" for o in OFFICES] + [f"pickup({i})" for i in (1, 2, 3)]
                         + [f"deliver({i})" for i in (1, 2, 3)])


@settings(max_examples=30)
@given(requests=st.lists(st.tuples(office, office), min_size=0, max_size=3),
       moves=st.lists(action, max_size=8))
def test_the_standing_planner_finds_plans_as_short_as_a_fresh_search(mailbot, requests, moves):
    _, _, fresh, standing = mailbot
    state = state_after(fresh, requests, moves)
    a, b = fresh.plan(state), standing.plan(state)
    assert b is not None and a is not None
    assert b.length == a.length and not b.partial
    assert b.states[0] == state
    # the plan's predictions are what the domain says its actions do
    s = state
    for step, predicted in zip(b.steps, b.states[1:]):
        est = fresh.estimate(s, step)
        assert est.unique and est.state == predicted
        s = predicted
    assert fresh.plan(s).length == 0


def test_without_budget_the_plan_serves_the_oldest_goal_first_and_is_partial(mailbot):
    d, v, fresh, _ = mailbot
    state = state_after(fresh, [("office4", "office1"), ("office2", "office3")], [])
    agenda = [GoalLiteral(v.open_fluent(1), "false"), GoalLiteral(v.open_fluent(2), "false")]
    model = StandingModel(d, "serve", serve_roles(d, v), budget=0)
    plan = model.planner.plan(state, agenda)
    assert plan.partial and model.planner.stats.how == "oldest goal"
    end = plan.states[-1]
    assert end.value("pending(1)") == "false" and end.value("pending(2)") == "true"
    # the shortest plan that closes goal 1 alone: go to office4, pick up, come back, deliver
    assert plan.texts() == [["move(office2)"], ["move(office3)"], ["move(office4)"], ["pickup(1)"],
                            ["move(office3)"], ["move(office2)"], ["move(office1)"], ["deliver(1)"]]
    # with a budget, the same planner finds the plan for both at once (shorter than one after the other)
    exact = StandingModel(d, "serve", serve_roles(d, v)).planner.plan(state, agenda)
    assert not exact.partial and exact.length == fresh.plan(state).length == 10   # not 8 + 4


def test_a_partial_plan_is_followed_by_a_replan_and_every_goal_is_served(mailbot):
    d, v, _, _ = mailbot
    board = GoalBoard(v)
    model = StandingModel(d, "serve", serve_roles(d, v), budget=0, agenda=board.agenda)
    clock = VirtualClock()
    for text in ("deliver(office4,office1)", "deliver(office2,office3)", "deliver(office3,office1)"):
        board.submit(text)
    loop = OnlineLoop(model, SimulatedExecutor(model, clock=clock), [board], [board], when_done="wait", clock=clock)
    result = loop.run()
    assert result.status is OnlineStatus.GOAL_REACHED
    reasons = [r.replanned.reason for r in result.records if r.replanned is not None]
    assert reasons.count("partial") == 2 and reasons[:2] == ["start", "event"]
    assert [g.status.value for g in board.goals.values()] == ["succeeded"] * 3
    # goals are closed in the order they came
    assert [g.done_cycle for g in board.goals.values()] == sorted(g.done_cycle for g in board.goals.values())


def test_a_run_grounds_once_and_encodes_each_step_once(mailbot, monkeypatch):
    import cplus.api
    import cplus.sat.horizon
    import cplus.sat.templates
    from cplus.robot.serving.reactive import Server, ServerSettings
    calls = {"ground": 0, "templates": 0, "horizons": 0}

    def counting(name, fn):
        def wrapper(*a, **kw):
            calls[name] += 1
            return fn(*a, **kw)
        return wrapper
    monkeypatch.setattr(cplus.api, "ground_program", counting("ground", cplus.api.ground_program))
    monkeypatch.setattr(cplus.sat.templates, "build_templates", counting("templates", cplus.sat.templates.build_templates))
    monkeypatch.setattr(cplus.sat.horizon, "build_templates", counting("templates", cplus.sat.horizon.build_templates))
    monkeypatch.setattr(cplus.sat.horizon.Horizon, "__init__", counting("horizons", cplus.sat.horizon.Horizon.__init__))
    d = Domain.load(str(MAILBOT / "mailbot.cp"))
    server = Server(d, load_requests(str(MAILBOT / "requests.toml"), d), ServerSettings(clock=VirtualClock()))
    rng = random.Random(7)
    for _ in range(6):
        a, b = rng.sample(OFFICES, 2)
        server.board.submit(f"deliver({a},{b})")
    result = server.run()
    assert result.status is OnlineStatus.GOAL_REACHED and result.replans >= 2
    # one theory, one set of templates; solvers: the start state, the estimator, the planner,
    # and the simulated world's (none: it never needs one without surprises)
    assert calls["ground"] == 1 and calls["templates"] == 1
    assert calls["horizons"] == 3


@settings(max_examples=25)
@given(budget=st.integers(min_value=0, max_value=60_000),
       requests=st.lists(st.tuples(office, office), min_size=2, max_size=3))
def test_whatever_the_budget_the_plan_is_the_shortest_or_closes_the_oldest_goal(mailbot, budget, requests):
    d, v, fresh, _ = mailbot
    state = state_after(fresh, requests, [])
    agenda = [GoalLiteral(v.open_fluent(i), "false", i) for i in range(1, len(requests) + 1)]
    model = StandingModel(d, "serve", serve_roles(d, v), budget=budget)
    for _ in range(2):                            # the second time, with what the first one learned
        plan = model.planner.plan(state, agenda)
        end = plan.states[-1]
        assert end.value("pending(1)") == "false"
        if plan.partial:
            assert model.planner.stats.how == "oldest goal"
            assert any(end.value(f"pending({i})") == "true" for i in range(2, len(requests) + 1))
        else:
            assert plan.length == fresh.plan(state).length
