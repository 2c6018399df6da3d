"""State estimation and planning from a state (cplus.robot.online.estimation): the SAT side of the
online loop, on the delivery domain and on small inline domains."""
from __future__ import annotations

import doctest
from pathlib import Path

import pytest

import cplus.robot.online.estimation as estimation
from cplus.api import Domain
from cplus.errors import QueryError
from cplus.robot.online.estimation import EstimateStatus, OnlineModel, Roles

ROOT = Path(__file__).resolve().parent.parent
DELIVERY = ROOT / "domains" / "delivery" / "delivery.cp"


@pytest.fixture(scope="module")
def delivery() -> OnlineModel:
    d = Domain.load(str(DELIVERY))
    return OnlineModel(d, "deliver", Roles.of(d, observed=["press"], inferred=["missed"]))


def test_docstring_examples():
    result = doctest.testmod(estimation)
    assert result.failed == 0 and result.attempted > 0


def test_roles_split_the_actions(delivery):
    roles = delivery.roles
    assert sorted(gc.text for gc in roles.agent) == ["follow", "lowerTray", "raiseTray", "turn"]
    assert [gc.text for gc in roles.observed] == ["press"]
    assert [gc.text for gc in roles.inferred] == ["missed"]


def test_roles_refuse_an_unknown_name():
    d = Domain.load(str(DELIVERY))
    with pytest.raises(QueryError, match="'jump' is not an action constant"):
        Roles.of(d, observed=["jump"])


def test_initial_state_is_the_query_start(delivery):
    est = delivery.initial_state()
    assert est.unique
    assert est.state.text() == {"atLandmark": 1, "facing": "up", "trayUp": True, "letter(1)": False,
                                "letter(2)": False, "letter(3)": True, "letter(4)": False}


def test_initial_sensing_that_contradicts_the_start_is_named(delivery):
    al = delivery.by_text["atLandmark"]
    est = delivery.initial_state({al: 2})
    assert est.status is EstimateStatus.NONE and est.unexplained == ["sensed atLandmark=2"]


def test_an_open_start_names_the_fluents_left_open():
    d = Domain.from_text("""
:- constants p, q :: inertialFluent; a :: exogenousAction.
a causes p.
:- query label :: g; maxstep :: 0..2; 0: -p; maxstep: p.""")
    est = OnlineModel(d, "g", Roles.of(d)).initial_state()
    assert est.status is EstimateStatus.SEVERAL
    assert {gc.text: vs for gc, vs in est.open.items()} == {"q": ["true", "false"]} or \
        {gc.text: sorted(vs) for gc, vs in est.open.items()} == {"q": ["false", "true"]}


def test_plans_never_count_on_events(delivery):
    """Offline, the shortest plan lets the follower 'miss' landmarks; online, events are absent
    from plans, so the plan is the honest one."""
    plan = delivery.plan(delivery.initial_state().state)
    assert plan.texts() == [["follow"], ["follow"], ["turn"], ["lowerTray"], ["raiseTray"], ["follow"],
                            ["follow"]]
    assert [s.value("atLandmark") for s in plan.states] == [1, 2, 3, 3, 3, 3, 2, 1]


def test_plan_from_the_goal_is_empty(delivery):
    s0 = delivery.initial_state().state
    plan = delivery.plan(s0)
    final = plan.states[-1]
    again = delivery.plan(final)
    assert again.length == 0 and again.states == [final]


def test_estimate_follows_the_prediction(delivery):
    s0 = delivery.initial_state().state
    plan = delivery.plan(s0)
    al = delivery.by_text["atLandmark"]
    est = delivery.estimate(s0, plan.steps[0], sensed={al: 2})
    assert est.unique and est.state == plan.states[1] and est.inferred == []


def test_a_missed_landmark_is_inferred_from_sensing(delivery):
    s0 = delivery.initial_state().state
    plan = delivery.plan(s0)
    al = delivery.by_text["atLandmark"]
    est = delivery.estimate(s0, plan.steps[0], sensed={al: 3})
    assert est.unique and est.state.value("atLandmark") == 3
    assert [gc.text for gc in est.inferred] == ["missed"]
    assert {gc.text: v for gc, v in plan.states[1].diff(est.state).items()} == {"atLandmark": (2, 3)}


def test_an_observed_event_changes_the_state(delivery):
    s0 = delivery.initial_state().state
    plan = delivery.plan(s0)
    al = delivery.by_text["atLandmark"]
    est = delivery.estimate(s0, plan.steps[0], events=["press"], sensed={al: 2})
    assert est.unique and est.state.value("letter(1)") == "true"


def test_an_unexplainable_observation_is_named(delivery):
    s0 = delivery.initial_state().state
    plan = delivery.plan(s0)
    al = delivery.by_text["atLandmark"]
    est = delivery.estimate(s0, plan.steps[0], events=["press"], sensed={al: 4})
    assert est.status is EstimateStatus.NONE
    assert est.unexplained == ["sensed atLandmark=4"]       # the press is explainable, the 4 is not


def test_a_sensed_value_outside_the_domain_is_unexplained(delivery):
    s0 = delivery.initial_state().state
    plan = delivery.plan(s0)
    al = delivery.by_text["atLandmark"]
    est = delivery.estimate(s0, plan.steps[0], sensed={al: 9})
    assert est.status is EstimateStatus.NONE and "not a value of atLandmark" in est.unexplained[0]


def test_without_sensing_a_possible_miss_leaves_the_landmark_open(delivery):
    s0 = delivery.initial_state().state
    plan = delivery.plan(s0)
    est = delivery.estimate(s0, plan.steps[0])
    assert est.status is EstimateStatus.SEVERAL
    assert {gc.text: sorted(vs) for gc, vs in est.open.items()} == {"atLandmark": [2, 3]}


def test_the_estimator_is_one_solver_for_the_whole_run(delivery):
    s0 = delivery.initial_state().state
    plan = delivery.plan(s0)
    al = delivery.by_text["atLandmark"]
    delivery.estimate(s0, plan.steps[0], sensed={al: 2})
    solver = delivery._estimator().solver
    for _ in range(5):
        delivery.estimate(s0, plan.steps[0], sensed={al: 3})
        delivery.estimate(s0, plan.steps[0])
    assert delivery._estimator().solver is solver
    # the enumeration's blocking clauses were retired: the unique answer is still unique
    assert delivery.estimate(s0, plan.steps[0], sensed={al: 2}).unique


def test_a_condition_at_a_fixed_middle_step_is_refused():
    d = Domain.from_text("""
:- constants p :: inertialFluent; a :: exogenousAction.
a causes p.
:- query label :: g; maxstep :: 2; 0: -p; 1: p; maxstep: p.""", "g.cp")
    with pytest.raises(QueryError, match="condition at step 1 has no meaning") as info:
        OnlineModel(d, "g", Roles.of(d))
    assert info.value.render().startswith("g.cp:4:43: error:")


def test_attributes_travel_with_their_action():
    d = Domain.from_text("""
:- sorts place. :- objects a, b, c :: place. :- variables P :: place.
:- constants at :: inertialFluent(place); go :: exogenousAction; to :: attribute(place) of go.
go causes at=P if to=P.
:- query label :: g; maxstep :: 0..3; 0: at=a; maxstep: at=c.""")
    m = OnlineModel(d, "g", Roles.of(d))
    plan = m.plan(m.initial_state().state)
    assert plan.texts() == [["go(to=c)"]]
    act = plan.steps[0][0]
    assert act.attribute("to") == "c"
    est = m.estimate(plan.states[0], plan.steps[0])
    assert est.unique and est.state.value("at") == "c"
