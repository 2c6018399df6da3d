"""``cplus plan DOMAIN.pddl PROBLEM.pddl`` and ``cplus translate``: the plans (IPC format,
JSON), the concurrency, action costs, and every bad input as one located error, exit 2."""
from __future__ import annotations

import json

import pytest
from pddl_support import DOMAINS, need_up, run, validate_text

need_up()

BLOCKS = (DOMAINS / "blocks-domain.pddl", DOMAINS / "blocks-problem.pddl")
GRIPPER = (DOMAINS / "gripper-domain.pddl", DOMAINS / "gripper-problem.pddl")


def test_blocks_plan_is_printed_in_the_ipc_format_and_valid(capsys):
    code, out, err = run(["plan", *BLOCKS], capsys)
    assert code == 0, err
    lines = out.splitlines()
    assert lines[-1] == "; cost = 6 (unit cost)"
    assert all(line.startswith("(") and line == line.lower() for line in lines[:-1])
    assert len(lines) == 7
    assert validate_text(*BLOCKS, out)


def test_forall_step_puts_independent_actions_in_one_step(capsys):
    code, out, _ = run(["plan", *GRIPPER, "--json"], capsys)
    doc = json.loads(out)
    assert code == 0 and doc["format"] == "cplus.pddl-plan/1" and doc["semantics"] == "forall-step"
    assert doc["status"] == "found" and doc["validated"] is True
    assert len(doc["steps"]) < len(doc["plan"])                   # two picks share a step
    assert [a for s in doc["steps"] for a in s] == doc["plan"]
    assert doc["cost_kind"] == "action-costs" and doc["cost"] == 7
    code, out, _ = run(["plan", *GRIPPER, "--json", "--sequential"], capsys)
    seq = json.loads(out)
    assert seq["semantics"] == "sequential" and all(len(s) == 1 for s in seq["steps"])
    assert len(seq["plan"]) == 5


def test_minimize_total_cost_over_lengths(capsys):
    code, out, err = run(["plan", *GRIPPER, "--minimize", "total-cost", "--over-lengths", "--max-horizon", "6"],
                         capsys)
    assert code == 0, err
    assert out.splitlines()[-1] == "; cost = 7 (general cost)"
    assert validate_text(*GRIPPER, out)


def test_translate_writes_the_c_plus_theory_that_plans_alike(tmp_path, capsys):
    out_cp = tmp_path / "blocks.cp"
    code, _, err = run(["translate", *BLOCKS, "-o", out_cp], capsys)
    assert code == 0, err
    text = out_cp.read_text()
    assert "pick_up(block) :: exogenousAction" in text and "nonexecutable pick_up(Block1) & " in text
    code, out, err = run(["plan", out_cp], capsys)
    assert code == 0, err
    assert "ACTIONS:  unstack(c,b)" in out


def test_no_plan_in_a_small_state_space_is_a_proof(tmp_path, capsys):
    d = tmp_path / "d.pddl"
    p = tmp_path / "p.pddl"
    d.write_text("(define (domain d) (:requirements :strips) (:predicates (p) (r))\n"
                 " (:action a :parameters () :precondition (r) :effect (p)))\n")
    p.write_text("(define (problem q) (:domain d) (:init) (:goal (p)))\n")
    code, out, err = run(["plan", d, p], capsys)
    assert code == 10 and out == "" and "no plan exists" in err
    code, out, err = run(["plan", *BLOCKS, "--max-horizon", "3", "--json"], capsys)
    doc = json.loads(out)
    assert code == 3 and doc["status"] == "horizon_limit" and doc["proved"] is False and doc["plan"] is None


BAD_DOMAIN = {
    "durative": ("(define (domain d)\n  (:requirements :strips :durative-actions)\n  (:predicates (p)))\n",
                 ":2:26: error: requirement :durative-actions is not supported"),
    "numeric": ("(define (domain d)\n  (:requirements :strips :numeric-fluents)\n  (:predicates (p)))\n",
                ":2:26: error: requirement :numeric-fluents is not supported"),
    "syntax": ("(define (domain d)\n (:requirements :strips)\n (:predicates (p))\n"
               " (:action a :parameters () :precondition (and (p) (q)) :effect (not (p))))\n",
               ":4:52: error: Found invalid expression: q"),
    "either": ("(define (domain d)\n (:requirements :typing)\n (:types a b)\n (:predicates (p ?x - (either a b))))\n",
               ":4:23: error: 'either' types are not read by unified-planning's PDDL reader"),
    "not pddl": ("% a C+ file\n:- sorts a.\n", ":1:1: error: not a PDDL domain"),
}


@pytest.mark.parametrize("case", sorted(BAD_DOMAIN))
def test_a_bad_domain_is_one_located_error(case, tmp_path, capsys):
    text, wanted = BAD_DOMAIN[case]
    d = tmp_path / "d.pddl"
    p = tmp_path / "p.pddl"
    d.write_text(text)
    p.write_text("(define (problem q) (:domain d) (:init) (:goal (p)))\n")
    code, out, err = run(["plan", d, p], capsys)
    assert code == 2 and out == ""
    assert err.startswith(f"{d}{wanted}"), err
    assert "Traceback" not in err


def test_other_bad_inputs(tmp_path, capsys):
    code, _, err = run(["plan", tmp_path / "missing.pddl", BLOCKS[1]], capsys)
    assert code == 2 and err.strip() == f"cplus plan: error: {tmp_path / 'missing.pddl'}: no such file"
    code, _, err = run(["plan", GRIPPER[0], BLOCKS[1]], capsys)
    assert code == 2 and ":3:12: error: this problem is for domain 'blocks'" in err.splitlines()[0]
    code, _, err = run(["plan", *BLOCKS, "--minimize", "total-cost"], capsys)
    assert code == 2 and "has no action costs to minimize" in err and len(err.strip().splitlines()) == 1
    code, _, err = run(["plan", BLOCKS[0]], capsys)
    assert code == 2 and "give the domain and the problem" in err
    code, _, err = run(["plan", *BLOCKS, "--query", "x"], capsys)
    assert code == 2 and "--query applies to C+ files" in err
    code, _, err = run(["translate", *BLOCKS, "-o", BLOCKS[1]], capsys)
    assert code == 2 and "it is the problem this command reads" in err


def test_without_unified_planning_the_error_names_the_extra(monkeypatch, capsys):
    import sys
    monkeypatch.setitem(sys.modules, "unified_planning.io", None)
    code, _, err = run(["plan", *BLOCKS], capsys)
    assert code == 2 and err.strip() == ("cplus plan: error: PDDL input needs unified-planning: install the 'up' "
                                         "extra (pip install 'cplus[up]')")


ROADS = """(define (domain roads)
  (:requirements :typing :action-costs)
  (:types place)
  (:predicates (at ?p - place) (road ?a ?b - place))
  (:functions (road-length ?a ?b - place) - number (total-cost) - number)
  (:action drive :parameters (?a ?b - place)
    :precondition (and (at ?a) (road ?a ?b))
    :effect (and (not (at ?a)) (at ?b) (increase (total-cost) (road-length ?a ?b)))))
"""
ROADS_PROBLEM = """(define (problem r1) (:domain roads)
  (:objects s m t - place)
  (:init (at s) (road s t) (road s m) (road m t) (= (road-length s t) 10) (= (road-length s m) 2)
         (= (road-length m t) 3) (= (road-length t s) 1) (= (road-length m s) 1) (= (road-length t m) 1)
         (= (road-length s s) 0) (= (road-length m m) 0) (= (road-length t t) 0) (= (total-cost) 0))
  (:goal (at t)) (:metric minimize (total-cost)))
"""


def test_static_costs_and_the_proved_cheapest_plan(tmp_path, capsys):
    d, p = tmp_path / "roads.pddl", tmp_path / "r1.pddl"
    d.write_text(ROADS)
    p.write_text(ROADS_PROBLEM)
    code, out, _ = run(["plan", d, p], capsys)
    assert code == 0 and out == "(drive s t)\n; cost = 10 (general cost)\n"     # the shortest plan
    code, out, _ = run(["plan", d, p, "--minimize", "total-cost", "--over-lengths", "--json"], capsys)
    doc = json.loads(out)
    assert doc["plan"] == ["(drive s m)", "(drive m t)"] and doc["cost"] == 5
    assert doc["optimal"] == "cost"            # 3 atoms: every plan length was in the range


def test_a_numeric_fluent_beyond_costs_is_refused(tmp_path, capsys):
    d, p = tmp_path / "fuel.pddl", tmp_path / "f1.pddl"
    d.write_text(ROADS.replace("(increase (total-cost) (road-length ?a ?b))", "(decrease (road-length ?a ?b) 1)"))
    p.write_text(ROADS_PROBLEM)
    code, out, err = run(["plan", d, p], capsys)
    assert code == 2 and out == "" and "numeric" in err.splitlines()[0] and "Traceback" not in err


def test_a_type_and_a_predicate_may_share_a_name(tmp_path, capsys):
    d, p = tmp_path / "d.pddl", tmp_path / "p.pddl"
    d.write_text("(define (domain heat) (:requirements :typing) (:types temperature)\n"
                 " (:predicates (temperature ?x - object ?t - temperature) (hot ?t - temperature))\n"
                 " (:action warm :parameters (?x - object ?t - temperature) :precondition (hot ?t)\n"
                 "  :effect (temperature ?x ?t)))\n")
    p.write_text("(define (problem h) (:domain heat) (:objects cup - object warm - temperature)\n"
                 " (:init (hot warm)) (:goal (temperature cup warm)))\n")
    code, out, err = run(["plan", d, p], capsys)
    assert code == 0, err
    assert out == "(warm cup warm)\n; cost = 1 (unit cost)\n" and err == ""


def test_hostile_inputs_end_in_one_line(tmp_path, capsys):
    d, p = tmp_path / "big.pddl", tmp_path / "b.pddl"
    d.write_text("(define (domain big) (:requirements :strips) (:predicates (r ?x ?y))\n"
                 " (:action a :parameters (?x ?y) :precondition (r ?x ?y) :effect (not (r ?x ?y))))\n")
    p.write_text(f"(define (problem b) (:domain big) (:objects {' '.join(f'o{i}' for i in range(1500))})\n"
                 " (:init (r o1 o2)) (:goal (not (r o1 o2))))\n")
    code, out, err = run(["plan", d, p], capsys)
    assert code == 2 and out == ""
    assert err == "cplus plan: error: problem b has 2250000 ground atoms: more than cplus grounds (2000000)\n"
    code, out, err = run(["plan", "/dev/zero", p], capsys)
    assert code == 2 and err == "cplus plan: error: /dev/zero: larger than 8 MiB: not read as PDDL\n"
    code, out, err = run(["plan", tmp_path, p], capsys)
    assert code == 2 and err == f"cplus plan: error: {tmp_path}: is a directory, not a PDDL file\n"


UNDEFINED_COSTS = """(define (domain hops)
  (:requirements :typing :action-costs)
  (:types place)
  (:predicates (at ?p - place) (link ?a ?b - place))
  (:functions (hop-cost ?a ?b - place) - number (total-cost) - number)
  (:action hop :parameters (?a ?b - place)
    :precondition (at ?a)
    :effect (and (not (at ?a)) (at ?b) (increase (total-cost) (hop-cost ?a ?b)))))
"""


def test_an_instance_of_undefined_cost_is_not_applicable(tmp_path, capsys):
    """hop has no link precondition: only the cost function, defined for s-m and m-t alone,
    says where it goes (PDDL: an instance whose cost is undefined is not applicable)."""
    d, p = tmp_path / "hops.pddl", tmp_path / "h1.pddl"
    d.write_text(UNDEFINED_COSTS)
    p.write_text("(define (problem h1) (:domain hops) (:objects s m t - place)\n"
                 " (:init (at s) (= (hop-cost s m) 4) (= (hop-cost m t) 5) (= (total-cost) 0))\n"
                 " (:goal (at t)) (:metric minimize (total-cost)))\n")
    code, out, err = run(["plan", d, p], capsys)
    assert code == 0, err
    assert out == "(hop s m)\n(hop m t)\n; cost = 9 (general cost)\n"
    code, out, err = run(["translate", d, p], capsys)
    assert "nonexecutable hop(s,t)." in out and "nonexecutable hop(s,m)." not in out


def test_a_translation_beyond_the_limits_of_cplus_is_one_line(tmp_path, capsys):
    d, p = tmp_path / "wide.pddl", tmp_path / "w.pddl"
    d.write_text("(define (domain wide) (:requirements :typing) (:types o) (:predicates (p ?x - o))\n"
                 " (:action a :parameters (?a ?b ?c ?d ?e ?f ?g - o) :precondition (p ?a) :effect (not (p ?a))))\n")
    p.write_text(f"(define (problem w) (:domain wide) (:objects {' '.join(f'x{i}' for i in range(8))} - o)\n"
                 " (:init (p x1)) (:goal (not (p x1))))\n")
    code, out, err = run(["plan", d, p], capsys)
    assert code == 2 and out == "" and len(err.splitlines()) == 1
    assert err.startswith("cplus plan: error: problem w is beyond cplus's limits once translated to C+: 'a/7' has "
                          "2,097,152 ground instances")
