"""``cplus plan --jobs``: the same answers as the sequential planner, for every strategy.

The answers compared are those that do not depend on the solver's path: the plan length,
the horizons reported without a solution, and with ``-n 0`` the *set* of histories (on the
conformance corpus and on the oracle's random domains).  Besides: a worker killed in the
middle of a search is replaced and the answer does not change; Ctrl-C and SIGTERM end every
worker; ``--jobs auto`` after it went parallel; robot tasks; the command line's options.
Nothing here is timed: the speed is ``bench/bench_parallel.py``'s.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from cplus_oracle import first_histories
from cplus_random import descriptions
from hypothesis import assume, given, settings
from walltime import wall

from cplus import Domain
from cplus.cli import main
from cplus.history import to_object
from cplus.parallel import Strategy, solve_parallel

ROOT = Path(__file__).resolve().parents[2]
CORPUS = Path(os.environ.get("CPLUS_CORPUS", ROOT / "tests" / "corpus"))
STRATEGIES = [s.value for s in Strategy]

# long sequential runs (seconds each, and B's share of the horizons above the plan on top):
# their answers are compared by the benchmark, not here
LONG = {"examples/benchmarks/ferryman-etc/ferryman-30-4-benchmark.cp#0",
        "examples/benchmarks/hanoi-6-3/hanoi-6-3-benchmark.cp#0",
        "examples/benchmarks/ferryman-15-4/ferryman-15-4-benchmark.cp#0"}


def key(h) -> tuple:
    def cells(table):
        return frozenset((gc.text, str(to_object(gc, v))) for gc, v in table.items())
    return cells(h.rigid), tuple(cells(s) for s in h.states), tuple(cells(a) for a in h.actions)


def _cases():
    path = CORPUS / "manifest.json"
    cases = json.loads(path.read_text()) if path.is_file() else []
    return [pytest.param(c, id=c["id"]) for c in cases if c["id"] not in LONG]


def answer(result) -> tuple:
    found = {key(h) for h in result.histories}
    assert len(found) == len(result.histories), "a history came twice"
    return result.status, result.maxstep, list(result.failed), found


@pytest.mark.parametrize("case", _cases())
def test_corpus_answers_are_the_sequential_ones(case):
    """Every strategy on two workers, against one sequential run of the case."""
    path = str(CORPUS / "domains" / case["path"])
    counted = case["expected"].get("num_models") is not None
    n = 0 if counted else 1
    expected = answer(Domain.load(path).solve(case["query_label"], solutions=n, max_horizon=200))
    domain = Domain.load(path)       # one grounding for the three runs (each forks its workers from it)
    for strategy in STRATEGIES:
        got = solve_parallel(domain, case["query_label"], n, max_horizon=200, jobs=2, strategy=strategy)
        if counted:
            assert answer(got) == expected, strategy
        else:    # one plan: its length and the horizons proved empty
            assert answer(got)[:3] == expected[:3], strategy
        assert got.proved_shortest


@settings(max_examples=25)
@given(drawn=descriptions())
@pytest.mark.parametrize("strategy", STRATEGIES)
def test_random_domains_give_the_oracles_histories(strategy, drawn):
    """Exactly the oracle's histories, at the first maxstep of the range 0..m that has one."""
    desc, m = drawn
    expected = first_histories(desc, 0, m)
    assume(len(expected[1]) <= 600)
    r = solve_parallel(Domain.from_text(desc.text(m, 0)), solutions=0, jobs=2, strategy=strategy)
    found = {key(h) for h in r.histories}
    assert len(found) == len(r.histories)
    assert (r.maxstep, found) == expected


FERRY = CORPUS / "domains/examples/benchmarks/ferryman-10-4/ferryman-10-4-benchmark.cp"


def test_auto_going_parallel_gives_the_same_answer(monkeypatch):
    """``--jobs auto`` switched to workers after the first horizon (the threshold at zero)."""
    import cplus.parallel.plan as plan
    monkeypatch.setattr(plan, "available_cores", lambda: 2)
    monkeypatch.setattr(plan, "AUTO_SWITCH_S", 0.0)
    expected = Domain.load(str(FERRY)).solve("0", max_horizon=200)
    got = solve_parallel(Domain.load(str(FERRY)), "0", max_horizon=200, jobs="auto")
    assert got.parallel["parallel_from"] == expected.failed[0] + 1
    assert (got.maxstep, got.failed) == (expected.maxstep, expected.failed)
    assert [s.maxstep for s in got.stats] == [s.maxstep for s in expected.stats]


def test_auto_on_one_core_stays_in_this_process(monkeypatch):
    import cplus.parallel.plan as plan
    monkeypatch.setattr(plan, "available_cores", lambda: 1)
    got = solve_parallel(Domain.load(str(FERRY)), "0", max_horizon=200, jobs="auto")
    assert got.parallel["runs"] == [] and got.maxstep == 17


@pytest.mark.parametrize("strategy", ["A", "B"])
def test_a_killed_worker_is_replaced_and_the_answer_stays(strategy):
    """SIGKILL to the first worker as soon as the first horizon is reported (an event, not a
    delay). The first one started: it holds the shortest unfinished horizon then (under B
    always), so the search cannot end without seeing it die; a worker whose horizons were
    all above the plan could be killed unnoticed, and nothing would need replacing."""
    import multiprocessing
    killed: list[int] = []

    def started(proc) -> int:      # ForkProcess-N: N counts the processes this one started
        return int(proc.name.rsplit("-", 1)[1])

    def on_record(r: dict) -> None:
        if not killed:
            victim = min((c for c in multiprocessing.active_children() if c.pid not in before), key=started)
            os.kill(victim.pid, signal.SIGKILL)      # type: ignore[arg-type]
            killed.append(victim.pid)                # type: ignore[arg-type]
    expected = Domain.load(str(FERRY)).solve("0", max_horizon=200)
    before = {c.pid for c in multiprocessing.active_children()}    # not this search's workers
    got = solve_parallel(Domain.load(str(FERRY)), "0", max_horizon=200, jobs=2, strategy=strategy,
                         on_record=on_record)
    assert killed and got.parallel["workers_replaced"] >= 1
    assert (got.maxstep, got.failed) == (expected.maxstep, expected.failed)


def test_any_length_says_what_is_not_proved():
    """B with a window over many horizons finds a plan above the shortest before the proofs
    below it are done (whether it does depends on the solvers' paths: either way the result
    says which shorter horizons are open, and nothing proved is among them)."""
    r = solve_parallel(Domain.load(str(FERRY)), "0", max_horizon=200, jobs=2, strategy="B", any_length=True)
    assert r.maxstep is not None and r.maxstep >= 17
    info = r.parallel
    assert info["proved_shortest"] == (not info["not_proved_empty"])
    assert set(info["not_proved_empty"]).isdisjoint(r.failed)
    assert sorted(set(r.failed) | set(info["not_proved_empty"])) == list(range(1, r.maxstep))


def test_b_runs_the_shortest_horizon_alone_on_the_first_worker(monkeypatch):
    """Strategy B on two workers (issue 37): the first worker holds one horizon at a time, the
    shortest unfinished one, taken over from the worker that held it; never more horizons
    open than B's window; the answer is the sequential one."""
    from cplus.parallel import dispatch
    seen: list[tuple[int, int, int]] = []
    give = dispatch._Search._give

    def spy(self, m: int) -> None:
        give(self, m)
        head = self.procs[0]
        assert self.chain and set(head.load) <= {self.k}, (self.k, head.load)
        assert len(self.running) <= self.width
        seen.append((m, self.k, len(self.running)))
    monkeypatch.setattr(dispatch._Search, "_give", spy)
    sent: list[tuple[int, tuple]] = []
    send = dispatch._send

    def spy_send(p, msg: tuple) -> None:
        sent.append((p.wid, msg))
        send(p, msg)
    monkeypatch.setattr(dispatch, "_send", spy_send)
    expected = Domain.load(str(FERRY)).solve("0", max_horizon=200)
    got = solve_parallel(Domain.load(str(FERRY)), "0", max_horizon=200, jobs=2, strategy="B")
    assert (got.maxstep, got.failed) == (expected.maxstep, expected.failed)
    assert max(n for _, _, n in seen) <= dispatch.in_flight(Strategy.B, 2, 0.8)
    runs = got.parallel["runs"]
    first = [r["maxstep"] for r in runs if r["worker"] == 0 and r["result"] in ("sat", "unsat")]
    assert first == sorted(set(first)) and first, "the first worker goes up one horizon at a time"
    assert all(r["worker"] != 0 for r in runs if r["result"] == "taken")
    assert [w for w, msg in sent if msg[0] == "nice"] == [1], "only the other workers give way"
    assert all(w == 0 for w, msg in sent if msg[0] == "add" and msg[2] == 1.0), "k runs on the first worker"


def test_a_result_that_crosses_the_take_over_is_not_used(monkeypatch):
    """Worker 1 finds horizon 1 satisfiable just as the first worker takes it over (its "done"
    was on the way when the drop was sent): the search must not take that model (the drop
    removes it, so it could not be enumerated), record it once, as taken, and end with the
    first worker's answer. The scheduler is driven message by message with stand-in workers."""
    import types

    from cplus.parallel import dispatch
    sent: list[tuple[int, tuple]] = []
    monkeypatch.setattr(dispatch, "_send", lambda p, msg: sent.append((p.wid, msg)))
    work = types.SimpleNamespace(query=types.SimpleNamespace(lo=0, hi=None), max_horizon=10)
    search = dispatch._Search(work, 2, Strategy.B, 0.8, 1, False, None, None)
    search.procs = [dispatch._Proc(w, None, None) for w in range(2)]
    search._fill()
    head, other = search.procs
    assert search.running[0] is head and search.running[1] is other

    def stat(w: int, m: int, result: str) -> dict:
        return {"worker": w, "maxstep": m, "result": result}
    search._handle(head, ("done", 0, 0, False, stat(0, 0, "unsat"), None))     # 0 proved empty
    assert (1, ("drop", 1, "taken")) in sent and search.running[1] is head    # 1 taken over
    search._handle(other, ("done", 1, 1, True, stat(1, 1, "sat"), "model"))   # crossed the drop
    assert not search.done and 1 not in search.sat and search.running[1] is head
    search._handle(other, ("dropped", 1, 1, stat(1, 1, "taken")))             # the drop's answer
    search._handle(head, ("done", 0, 1, True, stat(0, 1, "sat"), "model"))
    assert search.done and search.answer == 1 and search.sat[1] is head
    assert [(r["worker"], r["maxstep"], r["result"]) for r in search.out.records] == [
        (0, 0, "unsat"), (1, 1, "taken"), (0, 1, "sat")]


def test_b_on_one_worker_time_shares_its_window():
    from cplus.parallel.strategy import chained
    assert chained(Strategy.B, 2) and chained(Strategy.B, 8)
    assert not chained(Strategy.B, 1) and not chained(Strategy.A, 2) and not chained(Strategy.SEQUENTIAL, 2)
    r = solve_parallel(Domain.load(str(FERRY)), "0", max_horizon=200, jobs=1, strategy="B")
    assert r.maxstep == 17 and r.failed == list(range(1, 17))
    assert not any(run["result"] == "taken" for run in r.parallel["runs"])


def test_no_plan_in_a_closed_range_is_proved_on_workers():
    d = Domain.from_text(""":- constants lit :: inertialFluent; flip :: exogenousAction.
flip causes lit.
:- query maxstep :: 0..4; 0: -lit; 0: lit.""")
    r = solve_parallel(d, jobs=2, strategy="B")
    assert r.status.value == "no_plan" and r.failed == [0, 1, 2, 3, 4]


# ---------------------------------------------------------------------------------- the command


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_json_has_the_parallel_account(capsys):
    code, out, err = run(["plan", str(FERRY), "--jobs", "2", "--strategy", "B", "--gamma", "0.5", "--json"], capsys)
    assert code == 0
    res = json.loads(out)["results"][0]
    assert res["maxstep"] == 17 and res["no_solution_with_maxstep"] == list(range(1, 17))
    par = res["parallel"]
    assert par["jobs"] == 2 and par["strategy"] == "B" and par["gamma"] == 0.5 and par["proved_shortest"]
    assert {r["worker"] for r in par["runs"]} <= {0, 1}
    assert {r["maxstep"] for r in par["runs"] if r["result"] == "unsat"} == set(range(1, 17))


def test_stats_are_per_worker_and_horizon(capsys):
    code, out, err = run(["plan", str(FERRY), "--jobs", "2", "--stats"], capsys)
    assert code == 0 and "17:" in out
    assert "% worker 0, maxstep" in err and "% worker 1, maxstep" in err and "strategy B" in err


@pytest.mark.parametrize("argv, message", [
    (["--strategy", "B"], "--strategy applies with --jobs N"),
    (["--any-length"], "--any-length applies with --jobs N"),
    (["--jobs", "2", "--gamma", "0.5"], "--gamma applies to --strategy B"),
    (["--jobs", "two"], "expected a positive integer"),
    (["--jobs", "2", "--strategy", "C"], "invalid choice"),
    (["--jobs", "2", "--strategy", "B", "--gamma", "0"], "must be > 0"),
])
def test_bad_options_are_one_line(argv, message, capsys):
    code, out, err = run(["plan", str(FERRY), *argv], capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1 and not out


def test_a_robot_task_refines_on_workers(capsys):
    """The payload task: the same length as sequentially, collision-free, nogoods shared."""
    from cplus.robot import RefineStatus, RobotTask, refine, refine_parallel
    path, scene = str(ROOT / "domains/payload/payload.cp"), str(ROOT / "domains/payload/scenes/island.toml")
    expected = refine(RobotTask.load(path, scene))
    got = refine_parallel(RobotTask.load(path, scene), jobs=2)
    assert got.status is RefineStatus.FOUND is expected.status
    assert got.history.maxstep == expected.history.maxstep          # type: ignore[union-attr]
    assert got.no_solution_with_maxstep == expected.no_solution_with_maxstep
    assert got.to_json()["parallel"]["proved_shortest"]


def test_a_robot_task_without_a_safe_plan_is_proved_on_workers():
    from cplus.robot import RefineStatus, RobotTask, refine_parallel
    path = str(ROOT / "domains/payload/payload.cp")
    task = RobotTask.load(path, str(ROOT / "domains/payload/scenes/raised-wall.toml"))
    got = refine_parallel(task, jobs=2, max_horizon=12)
    assert got.status is RefineStatus.NO_SAFE_PLAN or got.status is RefineStatus.HORIZON_LIMIT
    assert got.no_solution_with_maxstep == list(range(got.query.lo, 13))


# ---------------------------------------------------------------------------------- stopping


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(p) for p in text.split()]


def _gone(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return True
    return state in ("Z", "X")


HARD = """:- sorts loc.
:- objects 0..13 :: loc.
:- variables L, L1 :: loc.
:- constants at :: inertialFluent(loc); go(loc) :: exogenousAction.
go(L) causes at = L.
nonexecutable go(L) if at = L1 where L > L1 + 1.
nonexecutable go(L) if at = L1 where L < L1 - 1.
:- query maxstep :: 0..infinity; 0: at = 0; maxstep: at = 13 & at = 12.
"""


@pytest.mark.slow
@pytest.mark.parametrize("how", ["group-sigint", "sigterm"])
def test_interrupt_ends_every_worker(tmp_path, how):
    """Ctrl-C (SIGINT to the terminal's process group) or SIGTERM to the command, once its
    workers have reported a horizon: exit 130, one line, no traceback, no worker left."""
    f = tmp_path / "never.cp"
    f.write_text(HARD)        # no plan at any length: the search goes on until stopped
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "plan", str(f), "--jobs", "2", "--stats"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            start_new_session=True)
    try:
        seen = ""
        while "% worker" not in seen:
            line = proc.stderr.readline()          # type: ignore[union-attr]
            assert line, seen
            seen += line
        workers = _children(proc.pid)
        assert len(workers) == 2
        if how == "group-sigint":
            os.killpg(proc.pid, signal.SIGINT)
        else:
            proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=wall(60))
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert all(_gone(w) for w in workers)
