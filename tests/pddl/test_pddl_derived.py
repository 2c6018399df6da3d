"""PDDL 2.2 derived predicates: in preconditions, goals and effect conditions, recursive ones
against a brute-force search with its own reachability, and the errors, located.

unified-planning cannot represent derived predicates (its reader refuses ``(:derived``), so its
validator cannot check these plans: each test checks them itself, on explicit states."""
from __future__ import annotations

import itertools
import random
from collections import deque

import pytest

from tests.pddl.pddl_support import DOMAINS, need_up, run

need_up()

BRIDGES = (DOMAINS / "bridges-domain.pddl", DOMAINS / "bridges-problem.pddl")


def _plan_lines(out: str) -> list[tuple[str, ...]]:
    return [tuple(line.strip("()").split()) for line in out.splitlines() if line.startswith("(")]


# --- bridges: a recursive derived predicate (reachability) ------------------------------------

def _reach(bridges: set[tuple[str, str]]) -> set[tuple[str, str]]:
    """Pairs joined by a path of one bridge or more: a search from each island."""
    out = set()
    for start in {x for x, _ in bridges}:
        seen, todo = set(), [start]
        while todo:
            x = todo.pop()
            for a, b in bridges:
                if a == x and b not in seen:
                    seen.add(b)
                    todo.append(b)
        out |= {(start, y) for y in seen}
    return out


def _bridges_step(state, action):
    bridges, crews = state
    _, x, y = action
    if x not in crews or (x, y) in _reach(bridges):
        return None
    return bridges | {(x, y)}, crews - {x}


def _bridges_check(state, goal, plan) -> bool:
    for action in plan:
        state = _bridges_step(state, action)
        if state is None:
            return False
    return goal <= _reach(state[0])


def _bridges_shortest(islands, state, goal) -> int | None:
    """The fewest actions to the goal: breadth-first over explicit states."""
    seen = {state}
    queue = deque([(state, 0)])
    while queue:
        s, n = queue.popleft()
        if goal <= _reach(s[0]):
            return n
        for x, y in itertools.product(islands, repeat=2):
            t = _bridges_step(s, ("build", x, y))
            if t is not None and t not in seen:
                seen.add(t)
                queue.append((t, n + 1))
    return None


def _bridges_problem(islands, bridges, crews, goal) -> str:
    init = " ".join([*(f"(bridge {x} {y})" for x, y in sorted(bridges)), *(f"(crew {x})" for x in sorted(crews))])
    return (f"(define (problem r) (:domain bridges) (:objects {' '.join(islands)} - island)\n"
            f"  (:init {init})\n  (:goal (and {' '.join(f'(reach {x} {y})' for x, y in sorted(goal))})))\n")


def test_the_shipped_example_plans_and_a_loop_supports_nothing(capsys):
    code, out, _ = run(["plan", *BRIDGES, "--sequential"], capsys)
    assert code == 0
    plan = _plan_lines(out)
    state = (frozenset({("north", "south"), ("south", "north"), ("east", "harbour")}),
             frozenset({"north", "south", "west"}))
    goal = {("north", "harbour"), ("west", "north")}
    assert _bridges_check(state, goal, plan)
    # north and south reach each other only: under Clark completion alone they could support
    # (reach north harbour) in a loop and the plan would skip a bridge
    assert len(plan) == _bridges_shortest(["north", "south", "east", "west", "harbour"], state, goal) == 2
    code, out, _ = run(["plan", *BRIDGES], capsys)
    assert code == 0 and _bridges_check(state, goal, _plan_lines(out))


def test_recursive_reachability_against_breadth_first_search(tmp_path, capsys):
    islands = ["a", "b", "c", "d"]
    domain = BRIDGES[0]
    rng = random.Random(7)
    found = unsolvable = 0
    for k in range(8):
        pairs = [(x, y) for x in islands for y in islands]
        bridges = frozenset(p for p in pairs if rng.random() < 0.25)
        crews = frozenset(x for x in islands if rng.random() < 0.6)
        goal = set(rng.sample(pairs, 2))
        problem = tmp_path / f"p{k}.pddl"
        problem.write_text(_bridges_problem(islands, bridges, crews, goal))
        best = _bridges_shortest(islands, (bridges, crews), goal)
        code, out, err = run(["plan", domain, problem, "--sequential", "--max-horizon", "5"], capsys)
        if best is None:
            assert code in (3, 10), err
            unsolvable += 1
            continue
        assert code == 0, err
        plan = _plan_lines(out)
        assert len(plan) == best, (k, plan, best)
        assert _bridges_check((bridges, crews), goal, plan)
        code, out, err = run(["plan", domain, problem], capsys)       # forall-step
        assert code == 0 and _bridges_check((bridges, crews), goal, _plan_lines(out)), err
        found += 1
    assert found >= 3 and unsolvable >= 1


def test_the_translation_unfolds_the_recursion_into_layers(tmp_path, capsys):
    out = tmp_path / "b.cp"
    code, _, err = run(["translate", *BRIDGES, "-o", out], capsys)
    assert code == 0, err
    text = out.read_text()
    assert "reach(island,island) :: sdFluent" in text and "bridge(island,island) :: inertialFluent" in text
    assert "0..25 :: reach_level" in text                      # 25 ground atoms of reach, 25 layers
    assert "caused reach(Island1,Island2) if reach_layer(25,Island1,Island2)." in text
    assert "reach_layer(Reach_level1+1,Island1,Island2) if" in text
    code, out2, _ = run(["plan", out, "--max-horizon", "3"], capsys)
    assert code == 0 and "build" in out2


# --- non-recursive ones: precondition, goal, effect condition --------------------------------

LIGHTS = """(define (domain lights)
  (:requirements :typing :negative-preconditions :conditional-effects :derived-predicates)
  (:types room switch)
  (:predicates (wired ?s - switch ?r - room) (on ?s - switch) (lit ?r - room) (at ?r - room)
               (seen ?r - room) (door ?r1 ?r2 - room) (dark-anywhere) (done))
  (:derived (lit ?r - room) (exists (?s - switch) (and (wired ?s ?r) (on ?s))))
  (:derived (dark-anywhere) (exists (?r - room) (not (lit ?r))))
  (:action flip :parameters (?s - switch) :precondition (not (on ?s)) :effect (on ?s))
  (:action walk :parameters (?from ?to - room)
    :precondition (and (at ?from) (door ?from ?to) (lit ?to))
    :effect (and (at ?to) (not (at ?from)) (seen ?to)))
  (:action finish :parameters ()
    :effect (when (not (dark-anywhere)) (done))))
"""


def _lights_problem(goal: str) -> str:
    return ("(define (problem l) (:domain lights) (:objects hall kitchen cellar - room s1 s2 s3 - switch)\n"
            "  (:init (at hall) (door hall kitchen) (door kitchen cellar)\n"
            "         (wired s1 hall) (wired s2 kitchen) (wired s3 cellar))\n"
            f"  (:goal {goal}))\n")


def _lights_check(plan, goal_seen=(), goal_done=False, goal_dark=None) -> bool:
    """The lights domain by hand: lit = a switch wired to the room is on."""
    wired = {"s1": "hall", "s2": "kitchen", "s3": "cellar"}
    doors = {("hall", "kitchen"), ("kitchen", "cellar")}
    on, at, seen, done = set(), "hall", set(), False

    def lit(r):
        return any(wired[s] == r for s in on)
    for action in plan:
        if action[0] == "flip":
            if action[1] in on:
                return False
            on.add(action[1])
        elif action[0] == "walk":
            if at != action[1] or (action[1], action[2]) not in doors or not lit(action[2]):
                return False
            at = action[2]
            seen.add(at)
        else:
            done = done or all(lit(r) for r in ("hall", "kitchen", "cellar"))
    dark = not all(lit(r) for r in ("hall", "kitchen", "cellar"))
    return set(goal_seen) <= seen and (done or not goal_done) and (goal_dark is None or dark == goal_dark)


def test_a_derived_predicate_in_a_precondition(tmp_path, capsys):
    d, p = tmp_path / "d.pddl", tmp_path / "p.pddl"
    d.write_text(LIGHTS)
    p.write_text(_lights_problem("(seen cellar)"))
    code, out, err = run(["plan", d, p, "--sequential"], capsys)
    assert code == 0, err
    plan = _plan_lines(out)
    assert _lights_check(plan, goal_seen=["cellar"]) and len(plan) == 4   # two flips, two walks


def test_a_derived_predicate_in_a_goal_and_an_effect_condition(tmp_path, capsys):
    d, p = tmp_path / "d.pddl", tmp_path / "p.pddl"
    d.write_text(LIGHTS)
    p.write_text(_lights_problem("(not (dark-anywhere))"))
    code, out, err = run(["plan", d, p, "--sequential"], capsys)
    assert code == 0, err
    plan = _plan_lines(out)
    assert _lights_check(plan, goal_dark=False) and len(plan) == 3
    p.write_text(_lights_problem("(done)"))
    code, out, err = run(["plan", d, p, "--sequential", "--json"], capsys)
    assert code == 0, err
    import json
    doc = json.loads(out)
    plan = [tuple(a.strip("()").split()) for a in doc["plan"]]
    assert doc["validated"] and doc["optimal"] == "length"
    assert _lights_check(plan, goal_done=True) and len(plan) == 4 and plan[-1] == ("finish",)


def test_the_plan_check_refuses_a_plan_against_a_derived_precondition(tmp_path):
    from unified_planning.plans import ActionInstance

    from cplus.pddl import read_problem
    from cplus.pddl.derived import check_plan
    d, p = tmp_path / "d.pddl", tmp_path / "p.pddl"
    d.write_text(LIGHTS)
    p.write_text(_lights_problem("(seen kitchen)"))
    task = read_problem(str(d), str(p))
    walk, flip = task.action("walk"), task.action("flip")
    hall, kitchen, s2 = (task.object(n) for n in ("hall", "kitchen", "s2"))
    assert "precondition of action 1" in check_plan(task, [[ActionInstance(walk, (hall, kitchen))]])
    assert check_plan(task, [[ActionInstance(flip, (s2,))], [ActionInstance(walk, (hall, kitchen))]]) is None
    assert check_plan(task, [[ActionInstance(flip, (s2,))]]) == "the goal does not hold at the end"


# --- errors ---------------------------------------------------------------------------------

HEAD = ("(define (domain d)\n (:requirements :typing :derived-predicates)\n (:types t)\n"
        " (:predicates (p ?x - t) (q ?x - t) (r ?x - t))\n")
ACTION = " (:action a :parameters (?x - t) :precondition (q ?x) :effect (r ?x)))\n"
PROBLEM = "(define (problem q) (:domain d) (:objects a b - t) (:init) (:goal (p a)))\n"

BAD = {
    "undeclared": (HEAD + " (:derived (z ?x - t) (q ?x))\n" + ACTION, PROBLEM,
                   "d.pddl:5:13: error: derived predicate 'z' is not declared in :predicates"),
    "arity": (HEAD + " (:derived (p ?x ?y - t) (q ?x))\n" + ACTION, PROBLEM,
              "d.pddl:5:13: error: derived predicate 'p' has 1 argument(s) in :predicates and 2 here"),
    "not stratified": (HEAD + " (:derived (p ?x - t) (not (r ?x)))\n (:derived (r ?x - t) (not (p ?x)))\n"
                       " (:action a :parameters (?x - t) :precondition (q ?x) :effect (q ?x)))\n", PROBLEM,
                       "d.pddl:5:13: error: derived predicate 'p' depends negatively on 'r'"),
    "effect": (HEAD + " (:derived (p ?x - t) (q ?x))\n"
               " (:action a :parameters (?x - t) :precondition (q ?x) :effect (and (r ?x) (not (p ?x)))))\n",
               PROBLEM, "d.pddl:6:81: error: action a changes derived predicate 'p'"),
    "init": (HEAD + " (:derived (p ?x - t) (q ?x))\n" + ACTION,
             "(define (problem q) (:domain d) (:objects a b - t) (:init (q a)\n  (p b)) (:goal (p a)))\n",
             "p.pddl:2:4: error: derived predicate 'p' is given in :init"),
    "body syntax": (HEAD + " (:derived (p ?x - t) (and (q ?x) (zz ?x)))\n" + ACTION, PROBLEM,
                    "d.pddl:5:35: error: Not able to handle: (zz ?x)"),
    "no head": (HEAD + " (:derived p (q ?x))\n" + ACTION, PROBLEM,
                "d.pddl:5:2: error: expected (:derived (NAME ?x - type ...) CONDITION)"),
    "no body": (HEAD + " (:derived (p ?x - t))\n" + ACTION, PROBLEM,
                "d.pddl:5:2: error: this derived predicate has no condition"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_derived_predicate_is_one_located_error(case, tmp_path, capsys):
    domain, problem, wanted = BAD[case]
    d, p = tmp_path / "d.pddl", tmp_path / "p.pddl"
    d.write_text(domain)
    p.write_text(problem)
    code, out, err = run(["plan", d, p], capsys)
    assert code == 2 and out == "", err
    assert err.startswith(f"{tmp_path}/{wanted}"), err
    assert "Traceback" not in err and "Warning" not in err


def test_a_recursion_too_large_to_unfold_is_refused_at_its_head(tmp_path, capsys):
    d, p = tmp_path / "d.pddl", tmp_path / "p.pddl"
    d.write_text(BRIDGES[0].read_text())
    names = [f"i{k}" for k in range(40)]                   # 1600 atoms of reach: 2,560,000 layered
    p.write_text(_bridges_problem(names, {("i0", "i1")}, {"i1"}, {("i1", "i2")}))
    code, out, err = run(["plan", d, p], capsys)
    assert code == 2 and out == ""
    assert f"{d}:8:14: error: recursive derived predicate 'reach' has 1600 ground atoms" in err


def test_an_atom_that_only_supports_itself_is_false(tmp_path, capsys):
    d, p = tmp_path / "d.pddl", tmp_path / "p.pddl"
    d.write_text("(define (domain d) (:requirements :derived-predicates) (:predicates (p) (r))\n"
                 " (:derived (p) (p))\n (:action a :parameters () :precondition (r) :effect (r)))\n")
    p.write_text("(define (problem q) (:domain d) (:init) (:goal (p)))\n")
    code, out, err = run(["plan", d, p], capsys)
    assert code == 10 and out == "" and "no plan exists" in err
