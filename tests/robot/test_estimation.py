"""The online model's answers (cplus.robot.online.estimation) on domains of a few constants,
where every state, plan and estimate can be written out: states and their text, the roles
of actions, completing a partial state, the successors of a state (one, none with the
observations that cannot hold together, several with the fluents left open), plans that
never count on an event, and how an action with attributes is printed."""
from __future__ import annotations

import pytest

from cplus.api import Domain
from cplus.errors import QueryError
from cplus.robot.online import estimation
from cplus.robot.online.estimation import (
    Act,
    EstimateStatus,
    OnlineModel,
    Plan,
    Roles,
    State,
    action_text,
    json_value,
    split_query,
    state_constants,
    user_actions,
)

LAMP = """
:- constants lit, broken :: inertialFluent; level :: inertialFluent(0..3); side :: rigid;
   flip, kick, fix :: exogenousAction; surge :: exogenousAction.
flip causes lit if -broken.  kick causes -lit.  fix causes -broken.
surge causes broken.  surge causes -lit.  exogenous side.
:- variables L :: 0..3.
flip causes level=L+1 if level=L where L < 3.
nonexecutable flip & kick.
:- query label :: on; maxstep :: 0..4; 0: -lit & level=0 & -broken & side; maxstep: lit & level=2.
:- query label :: open; maxstep :: 0..3; 0: -lit; maxstep: lit.
:- query label :: far; maxstep :: 3..infinity; 0: level=0 & -lit & -broken & side; maxstep: level=3.
:- query label :: never; maxstep :: 0..2; 0: level=0 & -lit & -broken & side; maxstep: level=3.
"""


@pytest.fixture(scope="module")
def lamp():
    return Domain.from_text(LAMP, "lamp.cp")


@pytest.fixture(scope="module")
def on(lamp):
    return OnlineModel(lamp, "on", Roles.of(lamp, observed=["kick"], inferred=["surge"]))


def gc(model, text):
    return model.by_text[text]


def test_roles(lamp):
    roles = Roles.of(lamp, observed=["kick"], inferred=["surge", "kick"])
    assert sorted(g.text for g in roles.agent) == ["fix", "flip"]
    assert [g.text for g in roles.observed] == ["kick"]
    assert [g.text for g in roles.inferred] == ["surge"]          # observed wins
    assert sorted(g.text for g in roles.events) == ["kick", "surge"]
    assert sorted(g.text for g in Roles.of(lamp).agent) == ["fix", "flip", "kick", "surge"]
    with pytest.raises(QueryError, match="'jump' is not an action constant of lamp.cp"):
        Roles.of(lamp, inferred=["jump"])


def test_roles_name_ground_instances_or_every_instance():
    d = Domain.from_text(":- sorts r. :- objects r1, r2 :: r. :- variables R :: r.\n"
                         ":- constants on(r) :: inertialFluent; press(r), go :: exogenousAction;\n"
                         "  spd :: attribute(1..2) of go.\n"
                         "press(R) causes on(R).\n"
                         "go causes on(r1) unless stuck.\n")
    assert sorted(g.text for g in Roles.of(d, observed=["press(r2)"]).observed) == ["press(r2)"]
    assert sorted(g.text for g in Roles.of(d, observed=["press"]).observed) == ["press(r1)", "press(r2)"]
    assert [g.text for g in user_actions(d)] == ["press(r1)", "press(r2)", "go"]    # no attribute, no ab
    assert [g.text for g in state_constants(d)] == ["on(r1)", "on(r2)"]


def test_state_text_value_diff_equality(on):
    s0 = on.initial_state().state
    assert s0.text() == {"lit": False, "broken": False, "level": 0, "side": s0.text()["side"]}
    assert list(s0.text()) == ["lit", "broken", "level", "side"]          # declaration order
    assert s0.value("level") == 0 and s0.value("lit") == "false"
    with pytest.raises(KeyError):
        s0.value("nothing")
    other = State({**{g: s0[g] for g in s0}, gc(on, "level"): 2})
    assert {g.text: v for g, v in s0.diff(other).items()} == {"level": (0, 2)}
    assert s0.diff(s0) == {}
    assert s0 == State(dict(s0)) and hash(s0) == hash(State(dict(s0))) and s0 != other and s0 != dict(s0)
    assert len(s0) == 4 and set(s0) == set(state_constants(on.domain))
    assert repr(s0) == f"State({s0.text()})"


def test_json_values():
    d = Domain.from_text(":- sorts s. :- objects f(1..2) :: s.\n"
                         ":- constants b :: inertialFluent; n :: inertialFluent(0..2); o :: inertialFluent(s).")
    b, n, o = (d.program.signature.lookup(x, 0) for x in "bno")
    ground = {g.decl.name: g for g in d.program.signature.ground}
    assert json_value(ground["b"], "true") is True and json_value(ground["b"], "false") is False
    assert json_value(ground["n"], 2) == 2
    assert json_value(ground["o"], ("f", 1)) == "f(1)"


def test_the_start_is_unique_or_open(lamp, on):
    est = on.initial_state()
    assert est.unique and est.status is EstimateStatus.UNIQUE and est.states == [est.state]
    assert est.state.text()["level"] == 0
    loose = OnlineModel(lamp, "open", Roles.of(lamp)).initial_state()
    assert loose.status is EstimateStatus.SEVERAL and not loose.unique and loose.state is None
    assert {g.text: vs for g, vs in loose.open.items()} == {"broken": ["true", "false"], "level": [0, 1, 2, 3],
                                                            "side": ["true", "false"]}
    assert len(loose.states) == estimation.MAX_STATES      # 16 of the 16 states with -lit
    sensed = OnlineModel(lamp, "open", Roles.of(lamp)).initial_state(
        {gc(on, "level"): 1, gc(on, "broken"): "false", gc(on, "side"): "true"})
    assert sensed.unique and sensed.state.text() == {"lit": False, "broken": False, "level": 1, "side": True}


def test_enumeration_stops_at_max_states(lamp, monkeypatch):
    monkeypatch.setattr(estimation, "MAX_STATES", 3)
    est = OnlineModel(lamp, "open", Roles.of(lamp)).initial_state()
    assert est.status is EstimateStatus.SEVERAL and len(est.states) == 3 and len(set(est.states)) == 3
    monkeypatch.setattr(estimation, "MAX_STATES", 1)
    est = OnlineModel(lamp, "open", Roles.of(lamp)).initial_state()
    assert est.unique and len(est.states) == 1


def test_sensing_at_the_start(on):
    est = on.initial_state({gc(on, "level"): 2})
    assert est.status is EstimateStatus.NONE and est.unexplained == ["sensed level=2"] and est.state is None
    est = on.initial_state({gc(on, "lit"): "true"})
    assert est.unexplained == ["sensed lit"]
    est = on.initial_state({gc(on, "lit"): "false", gc(on, "level"): 0})
    assert est.unique
    est = on.initial_state({gc(on, "level"): 7})
    assert est.unexplained == ["sensed level=7, not a value of level"]


def test_complete_a_partial_state(on):
    s0 = on.initial_state().state
    est = on.complete(dict(s0))
    assert est.unique and est.state == s0
    est = on.complete({gc(on, "lit"): "true", gc(on, "broken"): "false", gc(on, "level"): 3})
    assert est.status is EstimateStatus.SEVERAL and {g.text for g in est.open} == {"side"}
    est = on.complete({gc(on, "level"): 9})
    assert est.status is EstimateStatus.NONE and est.unexplained == ["level=9, not a value of level"]
    assert on.complete({gc(on, "lit"): "false"}).status is EstimateStatus.SEVERAL


def test_a_plan_from_a_state(on):
    s0 = on.initial_state().state
    plan = on.plan(s0)
    assert plan.texts() == [["flip"], ["flip"]] and plan.length == 2
    assert [s.text()["level"] for s in plan.states] == [0, 1, 2]
    assert [s.text()["lit"] for s in plan.states] == [False, True, True]
    assert plan.seconds >= 0 and not plan.partial
    rest = plan.rest()
    assert rest.texts() == [["flip"]] and rest.states == plan.states[1:] and rest.history.maxstep == 1
    assert rest.rest().length == 0 and rest.rest().states == [plan.states[2]]
    act = plan.steps[0][0]
    assert (act.name, act.value, act.text, dict(act.attributes)) == ("flip", "true", "flip", {})


def test_plans_never_count_on_events(lamp):
    """'surge' would break the lamp and 'kick' would turn it off: a plan needs neither, and a
    goal only an event reaches has no plan."""
    d = Domain.from_text(":- constants lit :: inertialFluent; flip, kick :: exogenousAction.\n"
                         "kick causes lit.\n"
                         ":- query label :: g; maxstep :: 0..3; 0: -lit; maxstep: lit.")
    assert OnlineModel(d, "g", Roles.of(d)).plan(State({d.program.signature.ground[0]: "false"})).texts() \
        in ([["flip", "kick"]], [["kick"]])
    m = OnlineModel(d, "g", Roles.of(d, observed=["kick"]))
    assert m.plan(m.initial_state().state) is None
    m = OnlineModel(d, "g", Roles.of(d, inferred=["kick"]))
    assert m.plan(m.initial_state().state) is None


def test_an_open_maxstep_range_is_bounded(lamp, monkeypatch):
    far = OnlineModel(lamp, "far", Roles.of(lamp), max_horizon=3)
    assert far.goal_query.hi == 3 and far.goal_query.lo == 0
    assert far.plan(far.initial_state().state).texts() == [["flip"]] * 3
    assert OnlineModel(lamp, "far", Roles.of(lamp), max_horizon=2).plan(far.initial_state().state) is None
    monkeypatch.setattr(estimation, "DEFAULT_MAX_HORIZON", 5)
    assert OnlineModel(lamp, "far", Roles.of(lamp)).goal_query.hi == 5
    never = OnlineModel(lamp, "never", Roles.of(lamp))
    assert never.goal_query.hi == 2 and never.plan(never.initial_state().state) is None


def test_estimates_of_the_next_state(on):
    s0 = on.initial_state().state
    flip = on.plan(s0).steps[0]
    est = on.estimate(s0, flip)
    assert est.unique and est.state.text()["lit"] is True and est.state.text()["level"] == 1
    assert est.inferred == [] and est.seconds >= 0
    # the observed kick switches it off again (flip and kick together are not executable)
    est = on.estimate(s0, flip, events=["kick"])
    assert est.status is EstimateStatus.NONE and est.unexplained == ["event kick"]
    est = on.estimate(s0, [], events=[gc(on, "kick")], sensed={gc(on, "broken"): "false"})
    assert est.unique and est.state.text()["lit"] is False
    # an inferred surge explains a lamp found broken
    est = on.estimate(s0, [], sensed={gc(on, "broken"): "true"})
    assert est.unique and est.state.text()["broken"] is True and est.state.text()["lit"] is False
    assert [g.text for g in est.inferred] == ["surge"]
    est = on.estimate(s0, flip, sensed={gc(on, "lit"): "false"})     # flip and surge cannot both be
    assert est.status is EstimateStatus.NONE and est.unexplained == ["sensed -lit"]
    # nothing sensed: the surge may or may not have happened
    assert on.estimate(s0, flip).inferred == []
    est = on.estimate(s0, flip, sensed={gc(on, "level"): 3})
    assert est.status is EstimateStatus.NONE and est.unexplained == ["sensed level=3"]
    est = on.estimate(s0, flip, sensed={gc(on, "level"): 5})
    assert est.unexplained == ["sensed level=5, not a value of level"]
    est = on.estimate(s0, flip, events=["kick"], sensed={gc(on, "level"): 3})
    assert est.status is EstimateStatus.NONE and set(est.unexplained) <= {"event kick", "sensed level=3"}
    assert len(est.unexplained) == 1        # a minimal set: either one alone cannot hold with the flip


def test_estimate_with_nothing_done_keeps_the_state(on):
    s0 = on.initial_state().state
    est = on.estimate(s0, [])
    assert est.status is EstimateStatus.SEVERAL                 # a surge may have happened
    assert {g.text: vs for g, vs in est.open.items()} == {"broken": ["true", "false"]}
    est = on.estimate(s0, [], sensed={gc(on, "broken"): "false"})
    assert est.unique and est.state == s0


def test_an_unexplained_event_of_no_role_is_named():
    d = Domain.from_text(":- constants lit :: inertialFluent; flip, kick :: exogenousAction.\n"
                         "flip causes lit. kick causes -lit. nonexecutable kick if -lit.\n"
                         ":- query label :: g; maxstep :: 0..3; 0: -lit; maxstep: lit.")
    m = OnlineModel(d, "g", Roles.of(d, inferred=["kick"]))
    s0 = m.initial_state().state
    est = m.estimate(s0, [], events=["kick"])
    assert est.status is EstimateStatus.NONE and est.unexplained == ["event kick"]


def test_an_action_with_attributes():
    d = Domain.from_text(":- sorts place; arm. :- objects a, b, c :: place; r1, r2 :: arm.\n"
                         ":- variables P :: place; R :: arm; N :: 1..2.\n"
                         ":- constants at(arm) :: inertialFluent(place); go(arm) :: exogenousAction;\n"
                         "  to(arm) :: attribute(place) of go(arm); speed(arm, arm) :: attribute(1..2) of go(arm);\n"
                         "  mode :: exogenousAction(place*).\n"
                         "go(R) causes at(R)=P if to(R)=P.\n"
                         "nonexecutable go(R) if speed(R, R) = 2.\n"
                         ":- query label :: g; maxstep :: 0..2; 0: at(r1)=a & at(r2)=a; maxstep: at(r1)=c.")
    m = OnlineModel(d, "g", Roles.of(d, observed=["mode"]))
    plan = m.plan(m.initial_state().state)
    (act,) = plan.steps[0]
    assert act.name == "go" and act.attribute("to") == "c"
    assert act.text.startswith("go(r1,to=c") and act.text.count("speed(")
    with pytest.raises(KeyError):
        act.attribute("colour")
    est = m.estimate(plan.states[0], plan.steps[0])     # mode, observed and not seen, is none
    assert est.unique and est.state.value("at(r1)") == "c" and est.state.value("at(r2)") == "a"
    assert m.estimate(plan.states[0], [], events=["mode"]).unique        # mode = some place: it changes nothing
    g = {x.text: x for x in d.program.signature.ground}
    assert action_text(g["go(r1)"], "true", {}) == "go(r1)"
    assert action_text(g["go(r1)"], "true", {g["speed(r1,r2)"]: 1, g["to(r1)"]: "b"}) == "go(r1,to=b,speed(r2)=1)"
    assert action_text(g["mode"], "b", {}) == "mode=b"
    assert estimation._atom(g["mode"], "b") == "mode=b"
    assert estimation._atom(g["go(r1)"], "true") == "go(r1)" and estimation._atom(g["go(r1)"], "false") == "-go(r1)"
    done = m.acts({g["go(r1)"]: "true", g["to(r1)"]: "b", g["speed(r1,r1)"]: "none", g["speed(r1,r2)"]: 2,
                   g["go(r2)"]: "false", g["to(r2)"]: "none", g["mode"]: "a"})
    assert [(a.text, {k.text: v for k, v in a.attributes.items()}) for a in done] == [
        ("go(r1,to=b,speed(r2)=2)", {"to(r1)": "b", "speed(r1,r2)": 2})]


def test_a_non_boolean_action_of_the_agent():
    d = Domain.from_text(":- sorts place. :- objects a, b :: place.\n"
                         ":- constants at :: inertialFluent(place); move :: exogenousAction(place*).\n"
                         ":- variables P :: place. move=P causes at=P.\n"
                         ":- query label :: g; maxstep :: 0..2; 0: at=a; maxstep: at=b.")
    m = OnlineModel(d, "g", Roles.of(d))
    plan = m.plan(m.initial_state().state)
    assert plan.texts() == [["move=b"]]
    est = m.estimate(plan.states[0], [])            # nothing done: move=none
    assert est.unique and est.state.value("at") == "a"
    est = m.estimate(plan.states[0], plan.steps[0])
    assert est.unique and est.state.value("at") == "b"


def test_split_query():
    d = Domain.from_text(":- constants p, q :: inertialFluent; a :: exogenousAction. a causes p.\n"
                         ":- variables T :: step.\n"
                         ":- query label :: g; maxstep :: 2; 0: -p & q; maxstep: p; [\\/T | T: q].", "s.cp")
    start, goal = split_query(d.query("g"))
    assert len(start) == 1 and len(goal) == 2        # '0: -p & q' is one stamped item
    with pytest.raises(QueryError) as info:
        split_query(Domain.from_text(":- constants p :: inertialFluent.\n"
                                     ":- query label :: g; maxstep :: 2;\n  2: p.", "m.cp").query("g"))
    assert info.value.render().startswith("m.cp:3:3: error: a condition at step 2 has no meaning when the plan "
                                          "starts from the current state: stamp start conditions '0:' and goals "
                                          "'maxstep:'")


def test_a_value_that_is_not_a_value_is_refused(on):
    h = on._estimator()
    with pytest.raises(ValueError, match="'7' is not a value of level"):
        on._lit(h, gc(on, "level"), 7, 0)


def test_plan_and_act_values():
    p = Plan([], [], None, 1.5, True)  # type: ignore[arg-type]
    assert p.length == 0 and p.texts() == [] and p.partial
    a = Act(None, "true", {}, "x")  # type: ignore[arg-type]
    assert a.text == "x"


class _Clock:
    """A stand-in for the module's ``time``: each reading a quarter second after the last."""

    def __init__(self) -> None:
        self.now = 100.0

    def perf_counter(self) -> float:
        self.now += 0.25
        return self.now


def test_each_answer_says_how_long_it_took(on, monkeypatch):
    monkeypatch.setattr(estimation, "time", _Clock())
    s0 = on.initial_state().state
    level = gc(on, "level")
    answers = [on.initial_state(), on.initial_state({level: 9}), on.complete(dict(s0)), on.complete({level: 9}),
               on.estimate(s0, []), on.estimate(s0, [], sensed={level: 9})]
    assert [a.seconds for a in answers] == [0.25] * len(answers)


class _Solver:
    """A solver whose only conflict is observation 1: the others are explainable, alone or together."""

    def core(self) -> list[int]:
        return [1, 2, 3]

    def solve(self, assumptions) -> bool:
        return 1 not in assumptions


def test_the_unexplained_observations_are_a_minimal_set(on):
    class H:
        solver = _Solver()
    obs = {1: "event a", 2: "event b", 3: "sensed c", 4: "sensed d"}
    assert on._unexplained(H(), [1, 2, 3], obs, []) == ["event a"]


def test_plans_and_estimates_with_every_kind_of_fluent():
    """A statically determined and a simple fluent travel in the plan's states; an estimate looks
    one step ahead only (a state with no successor is still a state)."""
    d = Domain.from_text(":- constants lit, jammed :: inertialFluent; dark :: sdFluent; seen :: simpleFluent;\n"
                         "  flip :: exogenousAction.\n"
                         "flip causes lit. caused dark if -lit. default -dark. default -seen.\n"
                         "constraint false after lit & jammed.\n"
                         ":- query label :: g; maxstep :: 0..2; 0: -lit & jammed & -seen; maxstep: lit.")
    m = OnlineModel(d, "g", Roles.of(d))
    plan = m.plan(m.initial_state().state)
    assert plan.texts() == [["flip"]]
    assert [s.text() for s in plan.states] == [{"lit": False, "jammed": True, "dark": True, "seen": False},
                                               {"lit": True, "jammed": True, "dark": False, "seen": False}]
    est = m.estimate(plan.states[0], plan.steps[0])
    assert est.unique and est.state == plan.states[1]
