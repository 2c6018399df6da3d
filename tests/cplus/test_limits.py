"""Sizes that cannot fit are refused at once with the number that was too large, and Ctrl-C
while the SAT solver runs ends the command with "interrupted" and exit code 130.

The refusals run the real command in a subprocess under a 4 GB address-space limit (what a
careful user would set with ``ulimit -v``); the interrupt test sends a real SIGINT.
"""
from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import time

import pytest

from cplus import Domain
from cplus.errors import GroundingError
from cplus.limits import count, memory_budget

FOUR_GB = 4 * 10**9


def _limited() -> None:   # runs in the child before exec
    resource.setrlimit(resource.RLIMIT_AS, (FOUR_GB, FOUR_GB))


def plan(tmp_path, text: str, *extra: str) -> subprocess.CompletedProcess:
    p = tmp_path / "d.cp"
    p.write_text(text)
    return subprocess.run([sys.executable, "-m", "cplus", "plan", str(p), *extra], capture_output=True,
                          text=True, preexec_fn=_limited, timeout=120)


def one_error_line(proc: subprocess.CompletedProcess) -> str:
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    first = proc.stderr.splitlines()[0]
    assert ": error: " in first
    return first


def test_a_27_million_atom_product_is_refused_at_its_declaration(tmp_path):
    proc = plan(tmp_path, ":- sorts s.\n:- objects 1..300 :: s.\n"
                          ":- constants c(s,s,s) :: inertialFluent.\n:- query maxstep :: 1.\n")
    line = one_error_line(proc)
    assert line.startswith(f"{tmp_path / 'd.cp'}:3:14: error: ")
    assert "27,000,000 ground instances" in line


def test_atoms_past_memory_are_refused_even_below_the_count_of_constants(tmp_path):
    """Half a million constants are allowed, but with 2,000 values each they are a billion
    atoms: refused at the declaration, with the count and the memory it would need."""
    proc = plan(tmp_path, ":- sorts s; v.\n:- objects 1..500000 :: s; 1..2000 :: v.\n"
                          ":- constants c(s) :: inertialFluent(v).\n:- query maxstep :: 1.\n")
    line = one_error_line(proc)
    assert ":3:14: error: the constant 'c' has 500,000 ground instances (500,000 arguments)" in line
    assert "GiB of memory, more than the 1.9 GiB this run may use" in line


def test_a_horizon_past_memory_is_refused_with_its_maxstep(tmp_path):
    proc = plan(tmp_path, ":- constants p :: inertialFluent; a :: exogenousAction.\na causes p.\n"
                          ":- query maxstep :: 100000000000; maxstep: p.\n")
    line = one_error_line(proc)
    assert ":3:4: error: maxstep 100,000,000,000 means " in line


def test_a_law_with_too_many_instances_is_refused_before_grounding(tmp_path):
    text = (":- sorts s.\n:- objects 1..2000 :: s.\n:- variables X, Y, Z :: s.\n"
            ":- constants p(s) :: inertialFluent; q :: inertialFluent.\n"
            "caused q if p(X) & p(Y) & p(Z){where}.\n:- query maxstep :: 1.\n")
    line = one_error_line(plan(tmp_path, text.format(where="")))
    assert ":5:1: error: this law has about 8,000,000,000 instances (every combination of X, Y, Z)" in line
    # with a condition the share that passes it is estimated: about half of them here
    line = one_error_line(plan(tmp_path, text.format(where=" where X < Y")))
    assert "instances (the combinations that pass the conditions of X, Y, Z)" in line
    estimated = int(line.split("about ")[1].split(" ")[0].replace(",", ""))
    assert 3.5e9 < estimated < 4.5e9


def test_grounding_that_outgrows_memory_stops_with_the_rule_count(monkeypatch):
    """A law that yields many rules per binding (here one per value of a 50-valued fluent)
    passes the estimate and is stopped while it grounds (with a small budget, to be quick)."""
    import cplus.limits
    d = Domain.from_text(":- sorts s.\n:- objects 1..100 :: s.\n:- variables X, Y :: s.\n"
                         ":- constants q(s,s) :: simpleFluent(0..49).\n"
                         "inertial q(X,Y) where X < Y.\n:- query maxstep :: 1.\n")
    monkeypatch.setattr(cplus.limits, "memory_budget", lambda: 12000 * cplus.limits.RULE_BYTES)
    with pytest.raises(GroundingError) as exc:
        _ = d.theory
    assert "grounding reached" in str(exc.value) and "rules at this law" in str(exc.value)
    assert exc.value.loc is not None and exc.value.loc.line == 5


def test_what_fits_is_not_refused():
    d = Domain.from_text(":- sorts s.\n:- objects 1..30 :: s.\n:- variables X, Y :: s.\n"
                         ":- constants p(s,s) :: inertialFluent.\n"
                         "caused p(X,Y) if p(Y,X) where X < Y.\n:- query maxstep :: 2.\n")
    assert d.solve().maxstep == 2


def test_budget_follows_the_address_space_limit():
    code = ("import resource; resource.setrlimit(resource.RLIMIT_AS, (4 * 10**9, 4 * 10**9)); "
            "from cplus.limits import memory_budget; print(memory_budget())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert int(out) == 2 * 10**9
    assert memory_budget() > 0 and count(27_000_000) == "27,000,000"


PIGEONS = """:- sorts pigeon; hole.
:- objects 1..15 :: pigeon; 1..14 :: hole.
:- variables P, P1 :: pigeon; H :: hole.
:- constants at(pigeon) :: rigid(hole).
exogenous at(P).
constraint -(at(P)=H & at(P1)=H) where P < P1.
:- query maxstep :: 0.
"""


@pytest.mark.parametrize("solver", ["glucose4", "cadical195", "lingeling"])
def test_ctrl_c_in_the_sat_solver_exits_130(tmp_path, solver):
    """Pigeonhole 15 -> 14 keeps any CDCL solver busy for minutes; SIGINT is sent once the
    command has grounded (the --stats line) and is inside the solver."""
    p = tmp_path / "pigeons.cp"
    p.write_text(PIGEONS)
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "plan", str(p), "--stats", "--solver", solver],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()
        assert "grounded" in line, line
        time.sleep(1.0)     # templates and encoding take milliseconds; the solver, minutes
        assert proc.poll() is None
        os.kill(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert out == ""
