"""What the README promises about `cplus plan`/`cplus ground` and the Python API, each shown.

Exit code 3 and ``horizon_limit``, 130 on Ctrl-C (a real process and SIGINT), ``--extern``
and the built-in ``between/3``, ``rigid``/``value``/``attributes`` in ``cplus.plan/1``, the
DIMACS comment lines, every solver the README names, ``Domain.plans`` and ``Domain.session``.
"""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from pysat.solvers import Solver

from cplus import Domain
from cplus.cli import main
from cplus.ground.theory import template_lit
from cplus.history import decode_history
from cplus.planner import find_horizon

ROOT = Path(__file__).resolve().parents[2]

LAMP = """:- constants lit :: inertialFluent; flip :: exogenousAction.
:- variables T :: step.
flip causes lit.
:- query label :: on; maxstep :: 0..infinity; 0: -lit; maxstep: lit.
:- query label :: never; maxstep :: 0..infinity; 0: -lit; maxstep: lit; [/\\T | T < maxstep ->> (T: -flip)].
"""


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def lamp(tmp_path) -> str:
    p = tmp_path / "lamp.cp"
    p.write_text(LAMP)
    return str(p)


# --------------------------------------------------------------------------- exit codes


def test_an_open_range_stopped_at_max_horizon_exits_3(lamp, capsys):
    code, out, err = run(["plan", lamp, "-q", "never", "--max-horizon", "3"], capsys)
    assert code == 3
    assert [line for line in out.splitlines() if line] == [f"No solution with maxstep {m}." for m in range(4)]
    assert "--max-horizon" in err and "Traceback" not in err


def test_horizon_limit_in_json(lamp, capsys):
    code, out, _ = run(["plan", lamp, "-q", "never", "--max-horizon", "2", "--json"], capsys)
    (res,) = json.loads(out)["results"]
    assert code == 3
    assert res["status"] == "horizon_limit" and res["maxstep"] is None and res["histories"] == []
    assert res["no_solution_with_maxstep"] == [0, 1, 2]
    assert res["query"]["max_maxstep"] is None      # the range itself is open


def test_the_worst_query_decides_the_exit_code(lamp, capsys):
    code, _, _ = run(["plan", lamp, "--max-horizon", "2"], capsys)
    assert code == 3              # 'on' is found (0), 'never' hits the limit (3)


def interruptible() -> None:
    """In the child: Ctrl-C as in a terminal (a test runner may have been started with
    SIGINT ignored, and an ignored signal stays ignored across exec)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _started(proc: subprocess.Popen, marker: str) -> str:
    """Read stderr until ``marker`` shows the process is at work (no timing involved)."""
    seen = ""
    while marker not in seen:
        line = proc.stderr.readline()   # type: ignore[union-attr]
        assert line, f"the process ended before {marker!r}: {seen}"
        seen += line
    return seen


@pytest.mark.slow
def test_ctrl_c_stops_plan_with_130_and_one_line(lamp):
    """A real process, a real SIGINT while it searches an endless open range."""
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "plan", lamp, "-q", "never", "--stats"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            preexec_fn=interruptible)
    try:
        _started(proc, "% maxstep 3:")
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err[-2000:]
    assert err.strip().splitlines()[-1] == "cplus: interrupted" and "Traceback" not in err
    assert "Solution" not in out and "ACTIONS" not in out


PIGEONS = """% ten pigeons, nine holes: hopeless, and hard for any SAT solver
:- sorts pigeon; hole. :- objects 1..10 :: pigeon; 1..9 :: hole. :- variables P, Q :: pigeon.
:- constants in(pigeon) :: hole.
exogenous in(P).
constraint in(P) \\= in(Q) where P < Q.
:- query maxstep :: 0.
"""


@pytest.mark.slow
def test_ctrl_c_inside_the_sat_solver_is_130_too(tmp_path):
    """pysat turns a SIGINT caught inside its C solver into its own error: still 130."""
    p = tmp_path / "pigeons.cp"
    p.write_text(PIGEONS)
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "plan", str(p), "--stats"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            preexec_fn=interruptible)
    try:
        _started(proc, "grounded")
        time.sleep(1.0)        # not a timed assertion: only makes "inside solve" likely
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err[-2000:]
    assert "Traceback" not in err and out == ""


# --------------------------------------------------------------------------- externals

EXTERN = '''
def near(x, y):
    """Grid points at most one apart."""
    return abs(x - y) <= 1


def double(x):
    return 2 * x
'''

HOPS = """:- sorts cell. :- objects 0..6 :: cell. :- variables C, D :: cell.
:- constants at :: inertialFluent(cell); go(cell) :: exogenousAction.
go(C) causes at=C.
nonexecutable go(C) if at=D where -near(C, D).
nonexecutable go(C) & go(D) where C @< D.
:- query maxstep :: 0..10; 0: at=0; maxstep: at=double(3).
"""


@pytest.fixture
def hops(tmp_path) -> tuple[str, str]:
    d, e = tmp_path / "hops.cp", tmp_path / "ext.py"
    d.write_text(HOPS)
    e.write_text(EXTERN)
    return str(d), str(e)


def test_extern_predicates_and_functions_shape_the_plan(hops, capsys):
    domain, ext = hops
    code, out, _ = run(["plan", domain, "--extern", ext, "--json"], capsys)
    (res,) = json.loads(out)["results"]
    assert code == 0 and res["maxstep"] == 6          # one cell per step, to cell 2*3
    (hist,) = res["histories"]
    assert [s["at"] for s in hist["states"]] == list(range(7))


def test_an_unknown_extern_is_a_located_error_and_a_broken_file_one_line(hops, tmp_path, capsys):
    domain, ext = hops
    code, _, err = run(["plan", domain], capsys)
    assert code == 2 and err.startswith(f"{domain}:4:") and "Traceback" not in err
    bad = tmp_path / "bad.py"
    bad.write_text("def near(x, y):\n    return x +\n")
    code, _, err = run(["plan", domain, "--extern", str(bad)], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "SyntaxError" in err


def test_extern_in_ground(hops, tmp_path, capsys):
    domain, ext = hops
    cnf = tmp_path / "h.cnf"
    code, _, _ = run(["ground", domain, "--extern", ext, "--maxstep", "2", "--dimacs", str(cnf)], capsys)
    assert code == 0
    models = dimacs_histories(cnf.read_text())
    # from any cell, two hops of at most one: every model moves by at most 1 per step
    assert models and all(abs(_cell(m, t + 1) - _cell(m, t)) <= 1 for m in models for t in range(2))


def _cell(model: frozenset, t: int) -> int:
    (v,) = [int(a.split("=")[1]) for a in model if a.startswith(f"{t}:at=")]
    return v


def test_between_is_built_in():
    d = Domain.from_text(""":- sorts n. :- objects 0..9 :: n. :- variables N :: n.
:- constants pick :: n. exogenous pick. constraint pick = N ->> between(3, 5, N).
:- query maxstep :: 0.""")
    assert sorted(h.value("pick") for h in d.solve(solutions=0).histories) == [3, 4, 5]


# --------------------------------------------------------------------------- JSON


def test_json_carries_rigid_values_and_attributes(tmp_path, capsys):
    p = tmp_path / "j.cp"
    p.write_text(""":- sorts box. :- objects b1, b2 :: box. :- variables B :: box.
:- constants size :: 1..3; heavy :: rigid;
  place(box) :: inertialFluent(0..2); push(box) :: exogenousAction; force(box) :: attribute(1..2) of push(box);
  light :: exogenousAction(0..2).
exogenous size. heavy. push(B) causes place(B)=1 if force(B)=1. push(B) causes place(B)=2 if force(B)=2.
:- query maxstep :: 1; 0: size=2 & place(b1)=0 & place(b2)=0 & light=1 & -push(b1); 0: push(b2) & force(b2)=2.
""")
    code, out, _ = run(["plan", str(p), "--json"], capsys)
    (hist,) = json.loads(out)["results"][0]["histories"]
    assert hist["rigid"] == {"size": 2, "heavy": True}
    assert hist["states"][1] == {"place(b1)": 0, "place(b2)": 2}
    assert hist["actions"] == [[{"action": "push(b2)", "attributes": {"force(b2)": 2}},
                                {"action": "light", "value": 1}]]


# --------------------------------------------------------------------------- DIMACS


def dimacs_histories(text: str) -> set[frozenset]:
    """Every model of a DIMACS file, read through its comment lines as 'step:atom' texts."""
    names, clauses, nvars = {}, [], 0
    for line in text.splitlines():
        if line.startswith("c "):
            _, var, name = line.split(" ", 2)
            names[int(var)] = name
        elif line.startswith("p cnf"):
            nvars = int(line.split()[2])
        elif line:
            clauses.append([int(x) for x in line.split()[:-1]])
    assert set(names) <= set(range(1, nvars + 1))
    out = set()
    with Solver(name="glucose4", bootstrap_with=clauses) as s:
        while s.solve():
            model = s.get_model()
            out.add(frozenset(names[v] for v in model if v > 0 and v in names))
            s.add_clause([-v for v in model if abs(v) in names])   # block this history
    return out


def planner_atoms(h) -> frozenset:
    """A history as the atoms DIMACS comments name: 't:c' for true Booleans, 't:c=v' else."""
    out = set()
    for t, table in [(None, h.rigid), *enumerate(h.states), *enumerate(h.actions)]:
        for gc, v in table.items():
            text = gc.text if gc.boolean else f"{gc.text}={v}"
            if gc.boolean and v is not True:
                continue
            out.add(text if t is None else f"{t}:{text}")
    return frozenset(out)


@pytest.mark.parametrize("text, maxstep", [
    (LAMP, 2),
    (":- maxAdditive :: 2. :- sorts s. :- objects x, y :: s. :- variables S :: s.\n"
     ":- constants r :: 0..1; at :: inertialFluent(s); go(s) :: exogenousAction;\n"
     "  k(s) :: attribute(1..2) of go(s); n :: additiveFluent(0..3).\n"
     "exogenous r. go(S) causes at=S. go(x) increments n by 1 if k(x)=2. nonexecutable go(x) & go(y).\n"
     ":- query maxstep :: 1; 0: n=0.", 1),
])
def test_dimacs_comments_name_every_atom_of_every_history(tmp_path, capsys, text, maxstep):
    """Decoding each model of the CNF through the `c N step:atom` lines gives exactly the
    histories the planner enumerates (true atoms only; hidden ones are not named)."""
    p, cnf = tmp_path / "d.cp", tmp_path / "d.cnf"
    p.write_text(text)
    code, _, _ = run(["ground", str(p), "--maxstep", str(maxstep), "--dimacs", str(cnf)], capsys)
    assert code == 0
    from cplus.planner import run_query
    from cplus.program import QuerySpec
    d = Domain.load(str(p))
    expected = {planner_atoms(h) for h in
                run_query(d.theory, QuerySpec("all", maxstep, maxstep, (), None), solutions=0).histories}
    visible = {gc.text for gc in d.theory.sig.ground if not gc.decl.hidden}
    got = {frozenset(a for a in m if a.split(":")[-1].split("=")[0] in visible)
           for m in dimacs_histories(cnf.read_text())}
    assert got == expected
    first = cnf.read_text().splitlines()[0]
    assert first.startswith("c 1 ")


# --------------------------------------------------------------------------- solvers

SOLVERS = {"glucose4": "glucose41", "cadical195": "cadical195", "minisat22": "minisat22"}   # the README's list


@pytest.mark.parametrize("solver", SOLVERS)
def test_each_listed_solver_is_the_one_used_and_gives_the_same_histories(solver, capsys, monkeypatch):
    import cplus.sat.solver as facade
    used = []
    native_init = facade._Native.__init__

    def recording(self, prefix):     # which pysat backend the facade starts
        used.append(prefix)
        native_init(self, prefix)
    path = str(ROOT / "domains" / "examples" / "blocks.cp")
    reference = {h.key() for h in Domain.load(path).solve(solutions=0).histories}
    monkeypatch.setattr(facade._Native, "__init__", recording)
    code, out, _ = run(["plan", path, "--solver", solver, "-n", "0", "--json"], capsys)
    assert code == 0 and set(used) == {SOLVERS[solver]}
    got = Domain.load(path).solve(solutions=0, solver=solver)
    assert {h.key() for h in got.histories} == reference
    assert len(json.loads(out)["results"][0]["histories"]) == len(reference)


# --------------------------------------------------------------------------- Python API


def test_domain_plans_is_lazy_and_complete(monkeypatch):
    import cplus.planner
    decoded = []
    real = cplus.planner.decode_history
    monkeypatch.setattr(cplus.planner, "decode_history", lambda s: decoded.append(1) or real(s))
    d = Domain.from_text(""":- sorts lamp. :- objects a, b :: lamp. :- variables L :: lamp.
:- constants lit(lamp) :: inertialFluent; flip(lamp) :: exogenousAction.
flip(L) causes lit(L).
:- query maxstep :: 0..2; 0: -lit(a); maxstep: lit(a).""")
    plans = d.plans()
    first = next(plans)
    assert first.maxstep == 1 and len(decoded) == 1       # one history read, no more
    rest = list(plans)
    everything = {h.key() for h in d.solve(solutions=0).histories}
    assert len(everything) == 4 and {h.key() for h in [first, *rest]} == everything


def test_domain_session_keeps_added_constraints_at_later_horizons(lamp):
    """Forbidding flip everywhere (as refinement does) holds at every horizon tried later."""
    d = Domain.load(lamp)
    session = d.session("on", max_horizon=4)
    assert find_horizon(session) == [0] and session.found == 1
    assert decode_history(session).actions[0]
    flip = next(gc for gc in d.theory.sig.ground if gc.text == "flip")
    session.horizon.forbid_everywhere(template_lit(d.theory.atoms.lit(flip, "true"), 0))
    assert not session.resolve()
    assert not session.solve_at(2) and not session.solve_at(3)   # later transitions too


def test_without_the_constraint_a_longer_horizon_has_plans(lamp):
    """(the control for the test above: at maxstep 2 the lamp can be switched on)"""
    session = Domain.load(lamp).session("on")
    assert not session.solve_at(0) and session.solve_at(1) and session.solve_at(2)


def test_console_interrupt_message_is_the_documented_one(monkeypatch, capsys, lamp):
    """The same path without a process: KeyboardInterrupt inside a command is 130."""
    import cplus.cli.plan as plan_cmd

    def interrupted(args):
        raise KeyboardInterrupt
    monkeypatch.setattr(plan_cmd, "main", interrupted)
    code, out, err = run(["plan", lamp], capsys)
    assert code == 130 and err == "cplus: interrupted\n" and out == ""

