"""cplus.up, the unified-planning engine: registered with the factory, it solves every example
problem of unified-planning's own test suite of a kind it declares, each plan valid."""
from __future__ import annotations

import pytest
from pddl_support import need_up

need_up()

from unified_planning.engines import PlanGenerationResultStatus as Status  # noqa: E402
from unified_planning.engines import SequentialPlanValidator, ValidationResultStatus  # noqa: E402
from unified_planning.shortcuts import OneshotPlanner, get_environment  # noqa: E402
from unified_planning.test.examples import get_example_problems  # noqa: E402

import cplus.up  # noqa: E402
from cplus.up import CPlusEngine  # noqa: E402

cplus.up.register()
get_environment().credits_stream = None
EXAMPLES = get_example_problems()


def _kind(problem):
    try:
        return problem.kind
    except Exception:  # noqa: BLE001 - a few examples have no computable kind (not for this engine)
        return None


SUPPORTED = sorted(n for n, e in EXAMPLES.items() if _kind(e.problem) is not None
                   and CPlusEngine.supports(e.problem.kind))


def test_the_engine_takes_a_fair_share_of_the_examples():
    assert len(SUPPORTED) >= 15
    assert "basic_with_costs" in SUPPORTED and "hierarchical_blocks_world_exists" in SUPPORTED


@pytest.mark.parametrize("name", SUPPORTED)
def test_every_supported_example_is_solved_with_a_valid_plan(name):
    problem = EXAMPLES[name].problem
    with OneshotPlanner(name="cplus", params={"max_horizon": 30}) as planner:
        result = planner.solve(problem)
    if not EXAMPLES[name].solvable:
        assert result.status in (Status.UNSOLVABLE_PROVEN, Status.UNSOLVABLE_INCOMPLETELY)
        return
    assert result.status in (Status.SOLVED_SATISFICING, Status.SOLVED_OPTIMALLY), result.status
    with SequentialPlanValidator() as validator:
        assert validator.validate(problem, result.plan).status is ValidationResultStatus.VALID


@pytest.mark.parametrize("name", ["basic", "robot_loader"])
def test_sequential_unit_cost_plans_are_optimal(name):
    problem = EXAMPLES[name].problem
    with OneshotPlanner(name="cplus", params={"sequential": True}) as planner:
        result = planner.solve(problem)
    assert result.status is Status.SOLVED_OPTIMALLY
    assert all(len(result.plan.actions) <= len(v.actions) for v in EXAMPLES[name].valid_plans)


def test_the_factory_picks_it_by_kind():
    problem = EXAMPLES["robot_loader"].problem
    with OneshotPlanner(problem_kind=problem.kind, name="cplus") as planner:
        assert planner.name == "cplus"
    assert "robot" in EXAMPLES and "REAL_FLUENTS" in EXAMPLES["robot"].problem.kind._features
    assert not CPlusEngine.supports(EXAMPLES["robot"].problem.kind)     # numeric fluents: never handed over


def test_unsolvable_proven_and_timeout():
    from unified_planning.shortcuts import BoolType, Fluent, InstantaneousAction, Problem
    p, r = Fluent("p", BoolType()), Fluent("r", BoolType())
    a = InstantaneousAction("a")
    a.add_precondition(r)
    a.add_effect(p, True)
    problem = Problem("never")
    for f in (p, r):
        problem.add_fluent(f, default_initial_value=False)
    problem.add_action(a)
    problem.add_goal(p)
    with OneshotPlanner(name="cplus") as planner:
        assert planner.solve(problem).status is Status.UNSOLVABLE_PROVEN
        assert planner.solve(problem, timeout=60).status is Status.UNSOLVABLE_PROVEN   # in a child process
    with OneshotPlanner(name="cplus", params={"max_horizon": 0}) as planner:
        assert planner.solve(problem).status is Status.UNSOLVABLE_INCOMPLETELY


def test_a_search_that_cannot_end_times_out():
    """No plan and 20 atoms (over PROOF_ATOMS): the range is open and the search would go on
    for ever; with a timeout the engine answers TIMEOUT (the child process is ended)."""
    from unified_planning.shortcuts import BoolType, Fluent, InstantaneousAction, Not, Problem
    problem = Problem("endless")
    bits = [Fluent(f"b{i}", BoolType()) for i in range(20)]
    goal = Fluent("goal", BoolType())
    for f in (*bits, goal):
        problem.add_fluent(f, default_initial_value=False)
    for i, f in enumerate(bits):
        flip = InstantaneousAction(f"flip{i}")
        flip.add_precondition(Not(f))
        flip.add_effect(f, True)
        problem.add_action(flip)
    problem.add_goal(goal)                     # nothing makes it true
    with OneshotPlanner(name="cplus") as planner:
        assert planner.solve(problem, timeout=2).status is Status.TIMEOUT
