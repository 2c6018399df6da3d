"""The command line: exit codes, CCALC's output format, JSON, statistics, DIMACS export."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from pysat.solvers import Solver

from cplus.cli import main

LAMP = """:- constants lit :: inertialFluent; flip :: exogenousAction.
flip causes lit.
:- query label :: on; maxstep :: 0..2; 0: -lit; maxstep: lit.
:- query label :: never; maxstep :: 1; 0: -lit; 1: -lit & [\\/X | X = 1]; 0: flip.
"""


@pytest.fixture
def lamp(tmp_path):
    p = tmp_path / "lamp.cp"
    p.write_text(LAMP.replace("[\\/X | X = 1]", "true"))
    return str(p)


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_plan_prints_ccalc_text(lamp, capsys):
    code, out, err = run(["plan", lamp, "--query", "on"], capsys)
    assert code == 0
    assert out == ("\nNo solution with maxstep 0.\n\n"
                   "\n0:\n\nACTIONS:  flip\n\n1:  lit\n\n\n")


def test_no_solution_has_its_own_exit_code(lamp, capsys):
    code, out, _ = run(["plan", lamp, "--query", "never"], capsys)
    assert code == 1
    assert out.strip() == "No solution with maxstep 1."


def test_every_query_runs_in_order(lamp, capsys):
    code, out, _ = run(["plan", lamp], capsys)
    assert code == 1
    assert out.index("% query on") < out.index("% query never")


def solutions(out: str) -> list[list[str]]:
    """The solutions of CCALC text, numbered 1, 2, ... in order: each the lines after its
    header (blank lines dropped, atoms of a line sorted)."""
    blocks = out.split("Solution ")[1:]
    assert [b.split(":", 1)[0] for b in blocks] == [str(k) for k in range(1, len(blocks) + 1)]
    return [[" ".join(sorted(line.split())) for line in b.split(":", 1)[1].splitlines() if line.strip()]
            for b in blocks]


def test_numbered_solutions_and_all(lamp, capsys, tmp_path):
    p = tmp_path / "two.cp"
    p.write_text(":- constants p, q :: inertialFluent. :- query maxstep :: 0.")
    code, out, _ = run(["plan", str(p), "-n", "0"], capsys)
    assert code == 0
    every = solutions(out)
    assert sorted(every) == [["0:"], ["0: p"], ["0: p q"], ["0: q"]]
    code, out, _ = run(["plan", str(p), "-n", "2"], capsys)
    two = solutions(out)
    assert len(two) == 2 and two[0] != two[1] and all(s in every for s in two)


def test_json_schema(lamp, capsys):
    code, out, _ = run(["plan", lamp, "--query", "on", "--json"], capsys)
    doc = json.loads(out)
    assert doc["format"] == "cplus.plan/1"
    (res,) = doc["results"]
    assert res["status"] == "found" and res["maxstep"] == 1
    assert res["no_solution_with_maxstep"] == [0]
    hist = res["histories"][0]
    assert hist["states"] == [{"lit": False}, {"lit": True}]
    assert hist["actions"] == [[{"action": "flip"}]]
    assert [s["maxstep"] for s in res["stats"]] == [0, 1]


def test_stats_go_to_stderr(lamp, capsys):
    code, out, err = run(["plan", lamp, "--query", "on", "--stats"], capsys)
    assert "% maxstep 0:" in err and "% maxstep 1:" in err and "clauses" in err and "solve" in err
    assert "grounded" in err and "%" not in out


def test_states_query(tmp_path, capsys):
    p = tmp_path / "s.cp"
    p.write_text(":- constants p :: inertialFluent; q :: sdFluent. caused q if p. default -q.")
    code, out, _ = run(["plan", str(p), "--query", "states", "-n", "0"], capsys)
    assert code == 0 and sorted(solutions(out)) == [["0:"], ["0: p q"]]


@pytest.mark.parametrize("argv, fragment", [
    (["plan", "/no/such.cp"], "no such file"),
    (["plan", "LAMP", "--query", "missing"], "no query with label 'missing'"),
    (["plan", "LAMP", "-n", "-1"], "non-negative"),
    (["plan", "LAMP", "--solver", "nope"], "unknown SAT solver"),
    (["plan", "LAMP", "--solver", "kissat404"], "cannot solve under assumptions"),   # it printed a wrong plan
    (["ground", "LAMP", "--maxstep", "x", "--dimacs", "-"], "non-negative"),
])
def test_bad_command_lines(argv, fragment, lamp, capsys):
    argv = [lamp if a == "LAMP" else a for a in argv]
    try:
        code = main(argv)
    except SystemExit as exc:   # argparse usage errors
        code = exc.code
    out, err = capsys.readouterr()
    assert code == 2
    assert fragment in err
    assert "Traceback" not in err


def test_an_unknown_label_is_the_command_lines_error_with_the_labels_there_are(lamp, capsys):
    # not located in the file: no line of it is wrong (its first line is a comment)
    code, _, err = run(["plan", lamp, "--query", "x"], capsys)
    assert (code, err) == (2, "cplus plan: error: --query x: no query with label 'x' (this file's labels: on, never)\n")
    code, _, err = run(["plan", lamp, "--nmquery", "x"], capsys)
    assert code == 2 and err.startswith("cplus plan: error: --nmquery x: no nmquery with label 'x'")
    code, _, err = run(["ground", lamp, "--query", "x", "--maxstep", "1", "--dimacs", os.devnull], capsys)
    assert code == 2 and err.startswith("cplus ground: error: --query x: no query with label 'x'")


def test_console_script_runs_as_a_process(lamp):
    proc = subprocess.run([sys.executable, "-m", "cplus", "plan", lamp, "--query", "on"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and "ACTIONS:  flip" in proc.stdout


def _count_models(nvars: int, clauses: list[list[int]]) -> int:
    n = 0
    with Solver(name="glucose4", bootstrap_with=clauses) as s:
        while s.solve():
            model = s.get_model()
            n += 1
            s.add_clause([-lit for lit in model[:nvars]])
    return n


def _read_dimacs(text: str):
    clauses, nvars = [], 0
    for line in text.splitlines():
        if line.startswith("p cnf"):
            nvars = int(line.split()[2])
        elif line and not line.startswith("c"):
            clauses.append([int(x) for x in line.split()[:-1]])
    return nvars, clauses


@pytest.mark.parametrize("text, query, maxstep", [
    (LAMP.replace("[\\/X | X = 1]", "true"), None, 2),
    (LAMP.replace("[\\/X | X = 1]", "true"), "on", 1),
    (":- maxAdditive :: 4. :- constants n :: additiveFluent(0..4); a, b :: exogenousAction; "
     "k :: attribute(1..2) of a. :- variables K :: 1..2. a increments n by K if k=K. "
     "b increments n by 1. :- query maxstep :: 2; 0: n=0.", "0", 2),
    (":- sorts s. :- objects x, y, z :: s. :- variables S :: s. :- constants at :: inertialFluent(s); "
     "go(s) :: exogenousAction. go(S) causes at=S. noconcurrency. nonexecutable go(S) if at=S. "
     ":- query maxstep :: 2.", None, 2),
])
def test_dimacs_models_are_the_histories(tmp_path, capsys, text, query, maxstep):
    """Models of the written CNF correspond one to one to the histories cplus plan counts."""
    p = tmp_path / "d.cp"
    p.write_text(text)
    out = tmp_path / "d.cnf"
    argv = ["ground", str(p), "--maxstep", str(maxstep), "--dimacs", str(out)]
    if query:
        argv += ["--query", query]
    code, _, err = run(argv, capsys)
    assert code == 0 and "wrote" in err
    nvars, clauses = _read_dimacs(out.read_text())
    from cplus import Domain
    from cplus.planner import run_query
    from cplus.program import QuerySpec
    d = Domain.load(str(p))
    q = d.query(query) if query else QuerySpec("all", maxstep, maxstep, (), None)
    q = QuerySpec(q.label, maxstep, maxstep, q.items, q.loc)
    histories = run_query(d.theory, q, solutions=0).histories
    assert _count_models(nvars, clauses) == len(histories) > 0


# --------------------------------------------------------------------------- promises


def test_version(capsys):
    from importlib.metadata import version
    code, out, err = run(["--version"], capsys)
    assert code == 0 and out == f"cplus {version('cplus')}\n" and err == ""


def test_every_option_of_every_command_has_help():
    import importlib

    from cplus.cli import COMMANDS
    for name in COMMANDS:
        parser = importlib.import_module(f"cplus.cli.{name}").build_parser()
        for action in parser._actions:
            assert action.help, f"cplus {name} {'/'.join(action.option_strings) or action.dest} has no help"


def test_plan_reads_standard_input():
    proc = subprocess.run([sys.executable, "-m", "cplus", "plan", "-", "--query", "on"],
                          input=LAMP.replace("[\\/X | X = 1]", "true"), capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "\nNo solution with maxstep 0.\n\n\n0:\n\nACTIONS:  flip\n\n1:  lit\n\n\n"


def test_errors_in_standard_input_are_located_there():
    proc = subprocess.run([sys.executable, "-m", "cplus", "plan", "-"], input=":- constants p :: inertialFluent.\ncaused q.",
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and proc.stderr.startswith("<stdin>:2:8: error: unknown name 'q'")


def test_the_label_states_prints_every_state(tmp_path, capsys):
    p = tmp_path / "s.cp"
    p.write_text(":- constants p, q :: inertialFluent.")
    code, out, _ = run(["plan", str(p), "--query", "states"], capsys)
    assert code == 0
    assert [line for line in out.splitlines() if line.startswith("Solution")] == [f"Solution {k}:" for k in range(1, 5)]
    assert sorted(line for line in out.splitlines() if line.startswith("0:")) == ["0:", "0:  p", "0:  p  q", "0:  q"]
    code, out, _ = run(["plan", str(p), "--query", "states", "-n", "1"], capsys)
    assert out.count("0:") == 1 and "Solution" not in out


def test_a_query_labelled_states_is_the_files_own(tmp_path, capsys):
    p = tmp_path / "s.cp"
    p.write_text(":- constants p, q :: inertialFluent. :- query label :: states; maxstep :: 0; 0: p & q.")
    code, out, _ = run(["plan", str(p), "--query", "states"], capsys)
    assert code == 0 and out.count("0:") == 1 and "Solution" not in out


def test_the_api_prints_what_the_command_prints(tmp_path, capsys):
    from cplus import Domain
    p = tmp_path / "two.cp"
    p.write_text(":- constants p, q :: inertialFluent. :- query maxstep :: 0; 0: p.")
    for n in (0, 1, 2):
        code, out, _ = run(["plan", str(p), "-n", str(n)], capsys)
        d = Domain.load(str(p))
        assert d.format(d.solve("0", solutions=n)) == out


def test_the_api_values_are_the_json_values(lamp, capsys):
    from cplus import Domain
    code, out, _ = run(["plan", lamp, "--query", "on", "--json"], capsys)
    hist = json.loads(out)["results"][0]["histories"][0]
    api = Domain.load(lamp).solve("on").histories[0]
    assert [api.state_values(t) for t in range(2)] == hist["states"] == [{"lit": False}, {"lit": True}]
    assert api.value("flip", 0) is True and api.value("lit", 1) is True


@pytest.mark.parametrize("target, fragment", [("NODIR/out.cnf", "no such directory"), (".", "it is a directory")])
def test_ground_checks_its_output_before_grounding(lamp, tmp_path, capsys, target, fragment):
    target = str(tmp_path / target.replace("NODIR", "missing")) if target != "." else str(tmp_path)
    code, out, err = run(["ground", lamp, "--maxstep", "1", "--dimacs", target], capsys)
    assert code == 2 and err.startswith(f"cplus ground: error: --dimacs {target}: {fragment}") and out == ""
    assert not (tmp_path / "missing").exists()      # a missing folder is not created
