"""bench/bench_ipc.py: the layouts of the IPC collections it reads, and one run of cplus on an
instance of domains/pddl (Fast Downward is not needed: it is the bench's own business)."""
from __future__ import annotations

import importlib.util
import json
import os

import pytest
from pddl_support import DOMAINS, ROOT, need_up

need_up()

spec = importlib.util.spec_from_file_location("bench_ipc", ROOT / "bench" / "bench_ipc.py")
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)


def test_the_layouts_of_the_collections(tmp_path):
    one = tmp_path / "potassco"
    (one / "instances").mkdir(parents=True)
    (one / "domain.pddl").write_text("")
    for n in (10, 2, 1):
        (one / "instances" / f"instance-{n}.pddl").write_text("")
    assert [p.name for _, p in bench.instances(one)] == ["instance-1.pddl", "instance-2.pddl", "instance-10.pddl"]
    each = tmp_path / "each"
    (each / "instances").mkdir(parents=True)
    (each / "domains").mkdir()
    for n in (1, 2):
        (each / "instances" / f"instance-{n}.pddl").write_text("")
        (each / "domains" / f"domain-{n}.pddl").write_text("")
    assert [(d.name, p.name) for d, p in bench.instances(each)] == [("domain-1.pddl", "instance-1.pddl"),
                                                                     ("domain-2.pddl", "instance-2.pddl")]
    fd = tmp_path / "fd"
    fd.mkdir()
    for stem in ("p01", "p02"):
        (fd / f"{stem}.pddl").write_text("")
    (fd / "p01-domain.pddl").write_text("")
    (fd / "domain_p02.pddl").write_text("")
    assert [(d.name, p.name) for d, p in bench.instances(fd)] == [("p01-domain.pddl", "p01.pddl"),
                                                                  ("domain_p02.pddl", "p02.pddl")]


def test_a_run_of_cplus(tmp_path, capsys):
    out = tmp_path / "rows.json"
    assert bench.main(["--pair", str(DOMAINS / "blocks-domain.pddl"), str(DOMAINS / "blocks-problem.pddl"),
                       "--planners", "cplus", "--time-limit", "300", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "% cplus: 1/1 solved" in text
    rows = json.loads(out.read_text())
    assert rows[0]["status"] == "solved" and rows[0]["actions"] == 6 and rows[0]["steps"] == 6


BLOCKS_PLAN = [("unstack", "c", "b"), ("put-down", "c"), ("unstack", "b", "a"), ("stack", "b", "c"),
               ("pick-up", "a"), ("stack", "a", "b")]


def test_plasps_atoms_read_into_steps():
    atoms = ['occurs(action(("stack",constant("a"),constant("b"))),3)', 'holds(variable("p"),value(variable("p"),true),1)',
             'occurs(action(("pick-up",constant("b"))),1)', 'occurs(action("go"),2)',
             'occurs(action(("pick-up",constant("a"))),1)']
    assert bench.plasp_steps(atoms) == [[("pick-up", "a"), ("pick-up", "b")], [("go",)], [("stack", "a", "b")]]


def test_plasps_plan_is_the_problems_and_validated():
    from unified_planning.engines import SequentialPlanValidator, ValidationResultStatus
    from unified_planning.io import PDDLReader
    task = PDDLReader().parse_problem(str(DOMAINS / "blocks-domain.pddl"), str(DOMAINS / "blocks-problem.pddl"))
    plan = bench.plasp_plan(task, [[a] for a in BLOCKS_PLAN])
    with SequentialPlanValidator() as validator:
        assert validator.validate(task, plan).status is ValidationResultStatus.VALID
    with pytest.raises(KeyError, match="fly"):
        bench.plasp_plan(task, [[("fly", "a")]])
    shorter = bench.plasp_plan(task, [[a] for a in BLOCKS_PLAN[1:]])
    with SequentialPlanValidator() as validator:
        assert validator.validate(task, shorter).status is not ValidationResultStatus.VALID


def test_plasps_installation_is_found_or_refused_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("CPLUS_PLASP", raising=False)
    assert bench.find_plasp(None) == (None, "no --plasp DIR and no $CPLUS_PLASP")
    top = tmp_path / "plasp"
    (top / "bin").mkdir(parents=True)
    (top / "bin" / "plasp").write_text("#!/bin/sh\n")
    (top / "bin" / "plasp").chmod(0o755)
    found, why = bench.find_plasp(str(top))
    assert found is None and "strips" in why
    (top / "encodings" / "strips").mkdir(parents=True)
    for name in bench.PLASP_ENCODINGS:
        (top / "encodings" / "strips" / name).write_text("")
    (top / "venv" / "bin").mkdir(parents=True)
    (top / "venv" / "bin" / "python").write_text("")
    found, why = bench.find_plasp(str(top))
    assert why == "" and found["plasp"] == str(top / "bin" / "plasp")
    assert found["clingo"] == [str(top / "venv" / "bin" / "python"), "-c", bench.CLINGO_MAIN]
    assert bench.main(["--pair", str(DOMAINS / "blocks-domain.pddl"), str(DOMAINS / "blocks-problem.pddl"),
                       "--planners", "plasp-seq,plasp-par", "--plasp", str(tmp_path / "none")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len([line for line in lines if "plasp" in line]) == 1 and "not found" in lines[0]


def test_a_run_of_plasp_against_cplus(tmp_path, capsys, monkeypatch):
    """With plasp installed ($CPLUS_PLASP, bench/build_plasp.sh): its forall-step plan is valid
    and as long in steps as cplus's."""
    if bench.find_plasp(None)[0] is None:
        pytest.skip("plasp + clingo not installed ($CPLUS_PLASP)")
    monkeypatch.setenv("CPLUS_PLASP", os.environ["CPLUS_PLASP"])     # main() sets it for its workers
    out = tmp_path / "rows.json"
    assert bench.main(["--pair", str(DOMAINS / "blocks-domain.pddl"), str(DOMAINS / "blocks-problem.pddl"),
                       "--planners", "cplus,plasp-seq,plasp-par", "--time-limit", "300", "--json", str(out),
                       "--plasp", os.environ["CPLUS_PLASP"]]) == 0
    rows = {r["planner"]: r for r in json.loads(out.read_text())}
    assert all(r["status"] == "solved" for r in rows.values()), rows
    assert rows["plasp-seq"]["actions"] == rows["plasp-par"]["steps"] == rows["cplus"]["steps"] == 6
    assert "invalid plans: 0" in capsys.readouterr().out
