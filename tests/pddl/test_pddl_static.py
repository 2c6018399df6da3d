"""Interference laws over static atoms (issue: zenotravel's flights did not ground): where two
actions require static atoms (a fuel level's ``next``), the forall-step laws keeping them apart
are written once per binding that makes those atoms true; the plans, their steps and the
proof of the shortest length are the ones the laws over every instance give."""
from __future__ import annotations

import json

import pytest
from pddl_support import need_up, run, validate_text

need_up()

DOMAIN = """(define (domain fuel)
  (:requirements :strips :typing)
  (:types plane city level)
  (:predicates (at ?p - plane ?c - city) (fuel ?p - plane ?l - level) (next ?l1 ?l2 - level))
  (:action fly :parameters (?p - plane ?from ?to - city ?l1 ?l2 - level)
    :precondition (and (at ?p ?from) (fuel ?p ?l1) (next ?l2 ?l1))
    :effect (and (not (at ?p ?from)) (at ?p ?to) (not (fuel ?p ?l1)) (fuel ?p ?l2)))
  (:action refuel :parameters (?p - plane ?l1 ?l2 - level)
    :precondition (and (fuel ?p ?l1) (next ?l1 ?l2))
    :effect (and (not (fuel ?p ?l1)) (fuel ?p ?l2))))
"""

PROBLEM = """(define (problem fuel-{n}) (:domain fuel)
  (:objects p1 p2 - plane c1 c2 c3 - city l0 l1 l2 l3 - level)
  (:init (at p1 c1) (at p2 c2) (fuel p1 l{f1}) (fuel p2 l{f2}) (next l0 l1) (next l1 l2) (next l2 l3))
  (:goal (and {goal})))
"""

CASES = [(1, 1, 0, "(at p1 c2) (at p2 c3)"), (2, 0, 1, "(at p1 c3) (at p2 c1)"),
         (3, 0, 0, "(at p1 c2) (at p2 c1) (fuel p1 l3)")]


def plan_json(tmp_path, capsys, n, f1, f2, goal):
    domain, problem = tmp_path / "domain.pddl", tmp_path / f"p{n}.pddl"
    domain.write_text(DOMAIN)
    problem.write_text(PROBLEM.format(n=n, f1=f1, f2=f2, goal=goal))
    code, out, err = run(["plan", domain, problem, "--json"], capsys)
    assert code in (0, 10), err
    return domain, problem, json.loads(out)


@pytest.mark.parametrize("n, f1, f2, goal", CASES)
def test_laws_per_static_binding_plan_as_the_laws_over_every_instance(tmp_path, capsys, monkeypatch, n, f1, f2, goal):
    import importlib
    translate = importlib.import_module("cplus.pddl.translate")   # the module (the package exports a function of its name)
    bound = plan_json(tmp_path, capsys, n, f1, f2, goal)[2]
    monkeypatch.setattr(translate, "STATIC_BINDINGS", -1)      # every law over all instances
    domain, problem, every = plan_json(tmp_path, capsys, n, f1, f2, goal)
    assert bound.get("steps") is not None
    assert len(bound["steps"]) == len(every["steps"])
    assert sum(map(len, bound["steps"])) == sum(map(len, every["steps"]))
    assert validate_text(domain, problem, "\n".join(a for step in bound["steps"] for a in step))


def test_the_laws_name_the_levels_next_allows(tmp_path, capsys):
    """fly & fly of one plane: one law per pair of level moves ``next`` allows, none for the rest."""
    domain, problem = tmp_path / "domain.pddl", tmp_path / "p.pddl"
    domain.write_text(DOMAIN)
    problem.write_text(PROBLEM.format(n=0, f1=1, f2=0, goal="(at p1 c2)"))
    out = tmp_path / "out.cp"
    code, _, err = run(["translate", domain, problem, "-o", out], capsys)
    assert code == 0, err
    laws = [line for line in out.read_text().splitlines() if line.startswith("nonexecutable fly(") and "& fly(" in line]
    assert laws and all(any(f",{lv}," in law or f",{lv})" in law for lv in ("l0", "l1", "l2", "l3")) for law in laws)
    pairs = {("l1", "l0"), ("l2", "l1"), ("l3", "l2")}           # fly's (?l1, ?l2) with next(?l2, ?l1)
    for law in laws:
        first = law.split("&")[0]
        levels = tuple(first.rstrip(") ").split("(")[1].split(",")[3:5])
        assert levels in pairs or not all(x.startswith("l") for x in levels), law
