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
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.errors import CPlusError, GroundingError
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


# --------------------------------------------------------------------------- conditions and tries
# issue 30: a condition that almost nothing passes made the grounder try every combination
# (``X + Y = 0`` over 0..99999: ten billion) before the size check could see anything.

SUMS = """:- sorts n.
:- objects 0..99999 :: n.
:- variables X, Y, Z :: n.
:- constants p :: inertialFluent; a :: exogenousAction.
a causes p where {condition}.
:- query maxstep :: 1; 0: -p; maxstep: p.
"""


def test_an_equation_binds_its_last_variable_instead_of_trying_every_value(monkeypatch):
    """X + Y = 0 over 0..99999 has one instance; Y is solved for, so grounding tries 100,000
    values of X and one Y each (under a limit of 300,000 tries, which trying every Y would
    pass ten-thousand-fold)."""
    import cplus.limits
    monkeypatch.setattr(cplus.limits, "MAX_TRIES", 300_000)
    d = Domain.from_text(SUMS.format(condition="X + Y = 0"))
    assert len(d.theory.rules["action"]) == 1 + 1       # the law's one instance, a's exogeneity
    assert d.solve().maxstep == 1


@pytest.mark.parametrize("condition, names, least", [
    ("X * Y * Z = 7", "X, Y, Z", 10**10),        # Z solved for: X and Y are ten billion pairs
    ("X * Y < 0", "X, Y", 10**10),               # no equation: every pair
])
def test_a_condition_that_would_try_billions_is_refused_at_once_with_the_number(tmp_path, condition, names, least):
    line = one_error_line(plan(tmp_path, SUMS.format(condition=condition)))
    assert line.startswith(f"{tmp_path / 'd.cp'}:5:1: error: this law is too large to ground: ")
    assert f"combinations of values of {names}, more than the 20,000,000 a law may try" in line
    estimated = int(line.split("trying about ")[1].split(" ")[0].replace(",", ""))
    assert least <= estimated <= 2 * least


def test_a_law_whose_tries_were_underestimated_is_stopped_at_the_limit(monkeypatch):
    """One X in 100,000 passes ``X mod 100000 = 99999`` (not an equation grounding can solve):
    no probe of the estimate gets past it, so the law starts, and it is stopped, located, when
    its tries reach the limit (a million Y, Z pairs behind that one X)."""
    import cplus.limits
    monkeypatch.setattr(cplus.limits, "MAX_TRIES", 500_000)
    text = (":- variables X :: 0..99999; Y, Z :: 0..999.\n"
            ":- constants p :: inertialFluent; a :: exogenousAction.\n"
            "a causes p where X mod 100000 = 99999 & Y + Z < 0.\n:- query maxstep :: 1.\n")
    with pytest.raises(GroundingError) as exc:
        _ = Domain.from_text(text).theory
    assert exc.value.loc is not None and (exc.value.loc.line, exc.value.loc.col) == (3, 1)
    assert "this law is too large to ground: it tried " in exc.value.message
    assert "combinations of values of X, Y, Z before it was stopped, more than the 500,000" in exc.value.message


EQUATION_LAW = """:- sorts n; m.
:- objects -3..5 :: n; 0..3 :: m; cell(m) :: m; a, b :: m.
:- variables X, Y :: n; Z :: m.
:- constants p(n, n, m) :: inertialFluent; go(n) :: exogenousAction; r, s :: inertialFluent(n).
go(X) causes p(X, Y, Z) where {left} = {right}.
caused s = X if r = X & p(X, Y, Z) where {left} = {right}.
:- query maxstep :: 0; 0: r = 0 & s = 1.
"""

_TERMS = st.deferred(lambda: st.sampled_from(["X", "Y", "Z", "0", "1", "-2", "7", "a", "cell(1)"])
                     | st.builds(lambda a, op, b: f"({a} {op} {b})", _TERMS, st.sampled_from(["+", "-", "*", "//", "mod"]),
                                 _TERMS)
                     | st.builds(lambda a: f"abs({a})", _TERMS))


@settings(max_examples=60, deadline=None)
@given(left=_TERMS, right=_TERMS)
def test_solving_equations_grounds_exactly_what_trying_every_value_does(left, right):
    """Over sorts of integers and of other objects, with arithmetic that is undefined on
    objects and divisions by zero: the same rules in the same order, or the same error, in
    the whole grounding and in the one restricted to the query's initial state (where the
    fluent atoms of a body bind their variables, :mod:`cplus.ground.restrict`)."""
    from cplus.ground import compile as grounding
    from cplus.ground import restrict
    text = EQUATION_LAW.format(left=left, right=right)

    def ground(solve: bool):
        saved = grounding.level_solvers
        if not solve:
            grounding.level_solvers = restrict.level_solvers = lambda levels: [None] * len(levels)
        try:
            d = Domain.from_text(text)
            restricted = d.theory_for(d.query("0"))          # before d.theory: see Domain.theory_for
            assert restricted.initial is not None
            full = Domain.from_text(text).theory
            return full.rules, full.constraints, restricted.rules, restricted.constraints
        except CPlusError as exc:
            return str(exc)
        finally:
            grounding.level_solvers = restrict.level_solvers = saved
    assert ground(True) == ground(False)


# --------------------------------------------------------------------------- additive encodings

ADDITIVE = """:- maxAdditive :: {top}.
:- sorts i.
:- objects 1..{k} :: i.
:- variables I :: i.
:- constants x :: additiveFluent(0..{top}); a(i) :: exogenousAction.
a(I) increments x by I.
:- query maxstep :: 1; 0: x = 0; maxstep: x = 5.
"""


def test_an_additive_fluent_too_large_to_encode_is_refused_at_its_declaration(monkeypatch):
    """A hundred thousand values and 40 contributions: about 8 million partial sums per step
    (3.7 GB and growing, unlocated, before the estimate); a budget of 1 GiB refuses it."""
    import cplus.limits
    monkeypatch.setattr(cplus.limits, "memory_budget", lambda: 1 << 30)
    d = Domain.from_text(ADDITIVE.format(top=99999, k=40))
    with pytest.raises(GroundingError) as exc:
        d.solve()
    assert exc.value.loc is not None and (exc.value.loc.line, exc.value.loc.col) == (5, 14)
    assert exc.value.message.startswith("the additive fluent 'x' is too large to encode: it sums 40 contributions "
                                        "over 100,000 values, about 8,0")
    assert "more than the 1.0 GiB this run may use" in exc.value.message


def test_an_additive_fluent_that_fits_is_encoded():
    d = Domain.from_text(ADDITIVE.format(top=200, k=40))
    assert d.solve().maxstep == 1


@settings(max_examples=80, deadline=None)
@given(lo=st.integers(-5, 5), width=st.integers(0, 12), fluent=st.booleans(),
       contributions=st.lists(st.lists(st.integers(-4, 4), min_size=1, max_size=4), max_size=5))
def test_the_size_of_an_additive_encoding_bounds_the_pairs_it_builds(lo, width, fluent, contributions):
    """:func:`sum_size` against the pairs the encoding keeps, counted by building the partial
    sums' values as the encoding does."""
    from types import SimpleNamespace

    from cplus.sat.templates import sum_size
    dom = tuple(range(lo, lo + width + 1))
    target = SimpleNamespace(domain=dom, decl=SimpleNamespace(kind="additiveFluent" if fluent else "additiveAction"))
    cgs = [SimpleNamespace(domain=tuple(sorted(set(c) | {0}))) for c in contributions]
    current = set(dom) if fluent else {0}
    mins, maxs = [min(c.domain) for c in cgs], [max(c.domain) for c in cgs]
    pairs = 0
    for j, c in enumerate(cgs):
        low, high = dom[0] - sum(maxs[j + 1:]), dom[-1] - sum(mins[j + 1:])
        kept = [u + w for u in current for w in c.domain if low <= u + w <= high]
        pairs += len(kept)
        current = set(kept)
    assert sum_size(SimpleNamespace(target=target, contributions=cgs)) >= pairs


# --------------------------------------------------------------------------- out of memory

def _out_of_memory(tmp_path, text: str, limit_mb: int) -> subprocess.CompletedProcess:
    """``cplus plan`` under an address-space limit, with the estimates told the machine is
    huge: what the limit stops is then the MemoryError itself."""
    p = tmp_path / "d.cp"
    p.write_text(text)
    code = (f"import resource, sys; resource.setrlimit(resource.RLIMIT_AS, ({limit_mb << 20}, {limit_mb << 20}))\n"
            "import cplus.limits, cplus.sat.horizon\n"
            "cplus.limits.memory_budget = cplus.sat.horizon.memory_budget = lambda: 1 << 50\n"
            "from cplus.cli import main\nsys.exit(main(['plan', sys.argv[1]]))\n")
    return subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("text, where, doing", [
    (":- sorts n.\n:- objects 0..1999 :: n.\n:- variables X, Y :: n.\n"
     ":- constants p :: inertialFluent; q(n) :: inertialFluent.\n"
     "caused p if q(X) & q(Y) where X < Y.\n:- query maxstep :: 1; maxstep: p.\n", ":5:1:", "grounding this law"),
    (ADDITIVE.format(top=5000, k=30), ":5:14:", "encoding the additive constant 'x'"),
])
def test_memory_running_out_is_a_located_too_large_error(tmp_path, text, where, doing):
    proc = _out_of_memory(tmp_path, text, 600)
    line = one_error_line(proc)
    assert line.startswith(f"{tmp_path / 'd.cp'}{where} error: too large: {doing} ran out of memory, "
                           f"more than the 600 MiB this run may use")


def test_the_solver_running_out_of_memory_is_located_at_the_query():
    from cplus.sat.horizon import QuerySession
    from cplus.sat.solver import SatSolver

    class Exhausted(SatSolver):
        def solve(self, assumptions=()):
            raise MemoryError

        def solve_limited(self, assumptions=(), propagations=0):
            raise MemoryError
    d = Domain.from_text(":- constants p :: inertialFluent; a :: exogenousAction.\na causes p.\n"
                         ":- query maxstep :: 0..3; 0: -p; maxstep: p.\n")
    q = d.query("0")
    session = QuerySession(d.theory, q, solver_factory=Exhausted, commit=True)
    with pytest.raises(GroundingError) as exc:
        session.solve_at(0)
    assert exc.value.loc == q.loc
    assert exc.value.message.startswith("too large: solving this query at maxstep 0 ran out of memory")
