"""``cplus batch``: job files, the results file and resuming from it, time and memory limits,
a lost worker, a portfolio, and the same batch on a real local Ray instance.

A lost worker is made deterministic: the job function kills its own process the first time
it runs a job (a marker file says whether it did), so the retry is certain to be needed and
to succeed.  The Ray test starts a local instance (2 CPUs, no dashboard, on the loopback
interface) and shuts it down; it is skipped only where Ray is not installed (CI installs it:
``.ci/run``).
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from walltime import wall

from cplus.batch import BatchError, Progress, ResultsFile, read_jobs, run_local
from cplus.cli import main
from cplus.cli.batch_job import run_job

ROOT = Path(__file__).resolve().parents[2]
LAMP = ROOT / "domains/examples/lamp.cp"
FERRY = ROOT / "tests/corpus/domains/examples/benchmarks/ferryman-10-4/ferryman-10-4-benchmark.cp"
HANOI = ROOT / "tests/corpus/domains/examples/benchmarks/hanoi-6-3/hanoi-6-3-benchmark.cp"
BW25 = ROOT / "bench/data/bw-25.cp"


def jobs_file(tmp_path: Path, lines: list[dict], name: str = "jobs.jsonl") -> Path:
    p = tmp_path / name
    p.write_text("".join(json.dumps(e) + "\n" for e in lines))
    return p


def records(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


# ------------------------------------------------------------------------------------- job files


def test_toml_jobs_with_defaults(tmp_path):
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "lamp.cp").write_text(LAMP.read_text())
    f = tmp_path / "jobs.toml"
    f.write_text('[defaults]\ntimeout = 30\noptions = { max_horizon = 5 }\n\n'
                 '[[job]]\ndomain = "d/lamp.cp"\nquery = "on"\n\n'
                 '[[job]]\nid = "x"\ndomain = "d/lamp.cp"\ntimeout = 2\nportfolio = "glucose4,minisat22"\n')
    a, b = read_jobs(str(f))
    assert (a.id, a.query, a.timeout, a.options) == ("d/lamp#on", "on", 30.0, {"max_horizon": 5})
    assert (b.id, b.timeout, b.portfolio) == ("x", 2.0, ["glucose4", "minisat22"])
    assert a.domain == str(tmp_path / "d" / "lamp.cp")


def test_a_folder_is_one_job_per_domain(tmp_path):
    for name in ("b.cp", "a.cp", "notes.txt"):
        (tmp_path / name).write_text(LAMP.read_text())
    assert [j.id for j in read_jobs(str(tmp_path))] == ["a", "b"]


@pytest.mark.parametrize("entry, message", [
    ({"domain": "nope.cp"}, "no such file"),
    ({"domain": str(LAMP), "timout": 3}, "unknown key 'timout'"),
    ({"domain": str(LAMP), "options": {"horizon": 3}}, "unknown option 'horizon'"),
    ({"domain": str(LAMP), "options": {"max_horizon": "3"}}, "option 'max_horizon': expected a non-negative maxstep"),
    ({"domain": str(LAMP), "timeout": -1}, "'timeout': must be > 0 and at most 1,000,000 seconds, got -1"),
    ({"id": 5}, "needs 'domain'"),
])
def test_bad_jobs_are_one_located_line(tmp_path, entry, message, capsys):
    f = jobs_file(tmp_path, [{"domain": str(LAMP)}, entry])
    with pytest.raises(BatchError, match=message):
        read_jobs(str(f))
    code, out, err = run(["batch", str(f)], capsys)
    assert code == 2 and message in err and ":2:" in err and len(err.strip().splitlines()) == 1


def test_duplicate_ids_and_unknown_solvers_are_refused(tmp_path, capsys):
    f = jobs_file(tmp_path, [{"domain": str(LAMP)}, {"domain": str(LAMP)}])
    code, _, err = run(["batch", str(f)], capsys)
    assert code == 2 and "two jobs have the id 'lamp'" in err
    f = jobs_file(tmp_path, [{"domain": str(LAMP), "portfolio": ["glucose4", "nosuch"]}], "p.jsonl")
    code, _, err = run(["batch", str(f)], capsys)
    assert code == 2 and "unknown solver or strategy 'nosuch'" in err


def test_ray_without_ray_says_how_to_get_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)      # import ray fails as if it were not installed
    f = jobs_file(tmp_path, [{"domain": str(LAMP)}])
    code, _, err = run(["batch", str(f), "--ray"], capsys)
    assert code == 2 and "pip install 'cplus[ray]'" in err and len(err.strip().splitlines()) == 1


# ------------------------------------------------------------------------------------- running


def test_a_batch_records_every_job_and_writes_the_summary(tmp_path, capsys):
    f = jobs_file(tmp_path, [{"id": "lamp", "domain": str(LAMP), "query": "on", "plans": True},
                             {"id": "ferry", "domain": str(FERRY), "options": {"jobs": 2, "strategy": "B"}},
                             {"id": "broken", "domain": str(LAMP), "query": "nosuch"}])
    code, out, err = run(["batch", str(f), "--workers", "2"], capsys)
    assert code == 1          # one job ended in an error
    got = {r["id"]: r for r in records(tmp_path / "jobs.results.jsonl")}
    assert got["lamp"]["status"] == "found" and got["lamp"]["maxstep"] == 1
    assert got["lamp"]["results"][0]["plans"][0]["states"][1]["lit"] is True
    assert got["ferry"]["status"] == "found" and got["ferry"]["maxstep"] == 17
    assert got["broken"]["status"] == "error" and "no query with label 'nosuch'" in got["broken"]["error"]
    csv = (tmp_path / "jobs.results.csv").read_text().splitlines()
    assert csv[0].startswith("id,status,maxstep") and [r.split(",")[0] for r in csv[1:]] == ["lamp", "ferry", "broken"]
    assert "% status" in err and "found" in err


def test_a_maxstep_any_query_is_proved_as_cplus_plan_proves_it(tmp_path, capsys):
    """The shipped lamp's every query: two plans and a proof that none switches it off (an
    error record before proofs were run)."""
    f = jobs_file(tmp_path, [{"id": "lamp", "domain": str(LAMP)}])
    code, _, err = run(["batch", str(f)], capsys)
    assert code == 0
    (rec,) = records(tmp_path / "jobs.results.jsonl")
    assert [(r["query"], r["status"]) for r in rec["results"]] == [
        ("0", "found"), ("on", "found"), ("never", "no_plan_proved")]
    assert rec["status"] == "no_plan_proved" and rec["error"] is None
    assert "% no_plan_proved      1" in err


def test_a_job_over_its_time_limit(tmp_path):
    rec = run_job(read_jobs(str(jobs_file(tmp_path, [{"domain": str(HANOI), "timeout": 0.3}])))[0].to_dict())
    assert rec["status"] == "timeout" and "0.3 s" in rec["error"]


def test_a_job_over_its_memory_limit(tmp_path):
    """bw-25 needs tens of MB beyond the interpreter; 10 MB is not enough: recorded, and the
    worker goes on with the next job (its limit is put back)."""
    f = jobs_file(tmp_path, [{"id": "big", "domain": str(BW25), "memory": 10}, {"id": "small", "domain": str(LAMP), "query": "on"}])
    out: list[dict] = []
    jobs = read_jobs(str(f))
    run_local(jobs, run_job, 1, 0, out.append, Progress(2, quiet=True))
    got = {r["id"]: r for r in out}
    assert got["big"]["status"] == "memory" and "10 MB" in got["big"]["error"]
    assert got["small"]["status"] == "found"


def killer(job: dict, attempt: int = 1) -> dict:
    """A job function whose first run of the job 'victim' kills its own worker process, and
    whose job 'stuck' never returns (ignoring its time limit, as a native solver may)."""
    if job["id"] == "stuck":
        import time
        time.sleep(3600)
    marker = Path(job["domain"]).with_name("killed-once")
    if job["id"] == "victim" and not marker.exists():
        marker.write_text("x")
        os.kill(os.getpid(), signal.SIGKILL)
    return run_job(job, attempt)


def always_killer(job: dict, attempt: int = 1) -> dict:
    """A job function whose every run of the job 'victim' kills its own worker process."""
    if job["id"] == "victim":
        os.kill(os.getpid(), signal.SIGKILL)
    return run_job(job, attempt)


def lamp_jobs(tmp_path: Path):
    (tmp_path / "lamp.cp").write_text(LAMP.read_text())
    return read_jobs(str(jobs_file(tmp_path, [{"id": "victim", "domain": "lamp.cp", "query": "on"},
                                              {"id": "other", "domain": "lamp.cp", "query": "on"}])))


def test_a_worker_lost_once_is_retried(tmp_path):
    """The pool breaks while both jobs run; each runs again alone, and both are answered."""
    out: list[dict] = []
    run_local(lamp_jobs(tmp_path), killer, 2, 1, out.append, Progress(2, quiet=True))
    got = {r["id"]: r for r in out}
    assert len(out) == 2 and (tmp_path / "killed-once").exists()
    assert got["victim"]["status"] == "found" and got["other"]["status"] == "found"


@pytest.mark.parametrize("retries", [0, 1])
def test_a_job_that_always_loses_its_worker_is_recorded_lost(tmp_path, retries):
    """Run alone after the first break, it is the one whose process dies: charged, and lost
    after its retries; the job beside it is not charged and is answered."""
    out: list[dict] = []
    run_local(lamp_jobs(tmp_path), always_killer, 2, retries, out.append, Progress(2, quiet=True))
    got = {r["id"]: r for r in out}
    assert len(out) == 2 and got["other"]["status"] == "found"
    assert got["victim"]["status"] == "lost" and got["victim"]["attempts"] == retries + 1


def test_a_portfolio_races_solvers(tmp_path, capsys):
    f = jobs_file(tmp_path, [{"id": "ferry", "domain": str(FERRY)}])
    code, _, _ = run(["batch", str(f), "--portfolio", "glucose4,minisat22,cadical195", "--quiet"], capsys)
    assert code == 0
    (rec,) = records(tmp_path / "jobs.results.jsonl")
    assert rec["status"] == "found" and rec["maxstep"] == 17
    assert rec["portfolio"]["winner"] in ("glucose4", "minisat22", "cadical195")
    assert rec["portfolio"]["finished"][rec["portfolio"]["winner"]] == "found"


# ------------------------------------------------------------------------------------- resuming


def test_resume_skips_finished_jobs_and_a_cut_line(tmp_path, capsys):
    f = jobs_file(tmp_path, [{"id": "a", "domain": str(LAMP), "query": "on"},
                             {"id": "b", "domain": str(LAMP), "query": "on"},
                             {"id": "c", "domain": str(LAMP), "query": "on"}])
    results = tmp_path / "jobs.results.jsonl"
    done = {"format": "cplus.batch/1", "id": "a", "status": "found", "maxstep": 1, "marker": "kept"}
    results.write_text(json.dumps(done) + "\n" + '{"format": "cplus.batch/1", "id": "b", "sta')   # a crash mid-line
    code, _, err = run(["batch", str(f)], capsys)
    assert code == 0 and "1 of 3 jobs done before" in err
    recs = records_ok(results)
    assert sorted(r["id"] for r in recs) == ["a", "b", "c"]
    assert recs[0]["id"] == "a" and recs[0].get("marker") == "kept"         # not redone
    assert set(ResultsFile(str(results)).records()) == {"a", "b", "c"}
    code, _, err = run(["batch", str(f), "--redo", "found", "--quiet"], capsys)
    assert code == 0 and ResultsFile(str(results)).records()["a"].get("marker") is None


def records_ok(path: Path) -> list[dict]:
    out = []
    for line in path.read_text().splitlines():
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            pass
    return out


@pytest.mark.slow
def test_an_interrupted_batch_resumes(tmp_path):
    """Ctrl-C once the first job is recorded: exit 130, what finished is kept, and the same
    command then runs only the rest."""
    never = tmp_path / "never.cp"
    never.write_text(":- constants lit :: inertialFluent; flip :: exogenousAction.\nflip causes lit.\n"
                     ":- query maxstep :: 0..infinity; 0: lit & -lit.\n")
    f = jobs_file(tmp_path, [{"id": "quick", "domain": str(LAMP), "query": "on"},
                             {"id": "endless", "domain": str(never)}])
    cmd = [sys.executable, "-m", "cplus", "batch", str(f), "--workers", "2"]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, cwd=ROOT, start_new_session=True)
    try:
        seen = ""
        while "quick: found" not in seen:
            line = proc.stderr.readline()      # type: ignore[union-attr]
            assert line, seen
            seen += line
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=wall(60))
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130 and "run the same command to resume" in err and "Traceback" not in err
    assert set(ResultsFile(str(tmp_path / "jobs.results.jsonl")).records()) == {"quick"}
    f.write_text(json.dumps({"id": "quick", "domain": str(LAMP), "query": "on"}) + "\n" +
                 json.dumps({"id": "endless", "domain": str(LAMP), "query": "on"}) + "\n")
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=wall(300))
    assert done.returncode == 0 and "1 of 2 jobs done before" in done.stderr


# ------------------------------------------------------------------------------------- one validator


@pytest.mark.parametrize("key, value, flag, text", [
    ("jobs", 0, "--jobs", "0"),
    ("jobs", 10 ** 20, "--jobs", str(10 ** 20)),
    ("n", -1, "-n", "-1"),
    ("max_horizon", 10 ** 9, "--max-horizon", str(10 ** 9)),
    ("max_iterations", -2, "--max-iterations", "-2"),
])
def test_a_batch_refuses_before_any_job_what_cplus_plan_refuses(tmp_path, capsys, key, value, flag, text):
    """The same check, the same words: ``cplus plan``'s one line after ``argument FLAG:`` is
    the batch's after ``option 'KEY':``, located at the line of the option, and no job runs."""
    (tmp_path / "lamp.cp").write_text(LAMP.read_text())
    f = tmp_path / "jobs.toml"
    f.write_text(f'[[job]]\ndomain = "lamp.cp"\n\n[[job]]\nid = "two"\ndomain = "lamp.cp"\n'
                 f'options = {{ {key} = {value} }}\n')
    code, out, err = run(["batch", str(f)], capsys)
    assert code == 2 and out == ""
    assert err.startswith(f"cplus batch: error: {f}:7: option '{key}': ") and err.count("\n") == 1, err
    assert not (tmp_path / "jobs.results.jsonl").exists()
    code, _, plan_err = run(["plan", str(LAMP), flag, text], capsys)
    assert code == 2
    assert plan_err.split(": ", 3)[3] == err.split(": ", 4)[4], (plan_err, err)


@pytest.mark.parametrize("line, message", [
    ('memory = inf', "3: 'memory': expected a positive whole number of megabytes up to 16,777,216, got inf"),
    ('memory = 0', "3: 'memory': expected a positive whole number of megabytes"),
    ('timeout = 1e300', "3: 'timeout': must be > 0 and at most 1,000,000 seconds, got 1e+300"),
    ('options = { extern = [1] }', "3: option 'extern': expected a list of file names"),
    ('options = { extern = ["nope.py"] }', "option 'extern': "),
    ('options = 3', "3: 'options' must be a table of cplus plan options"),
    ('options = { gamma = 0.5 }', "3: option 'gamma' applies to strategy B"),
    ('options = { jobs = 2, strategy = "B", gamma = 0 }', "3: option 'gamma': must be > 0 and at most 1, got 0"),
    ('options = { strategy = "A" }', "3: option 'strategy' applies with 'jobs'"),
    ('portfolio = ["glucose4", "glucose4"]', "3: 'portfolio': 'glucose4' twice"),
    ('portfolio = ""', "3: 'portfolio': unknown solver or strategy ''"),
    ('portfolio = "' + ",".join(["minisat22"] * 40) + '"', "3: 'portfolio': 'minisat22' twice"),
    ('solver = ""', "3: 'solver': an empty solver name"),
    ('solver = "glucose"', "3: 'solver': unknown SAT solver 'glucose' (did you mean 'glucose4'?)"),
    ('query = ""', "3: 'query': expected a query label, got an empty one"),
    ('plans = "no"', "3: 'plans': expected true or false, got 'no'"),
    ('timout = 3', "3: unknown key 'timout' (did you mean 'timeout'?)"),
])
def test_a_job_field_out_of_bounds_is_one_located_line(tmp_path, capsys, line, message):
    (tmp_path / "lamp.cp").write_text(LAMP.read_text())
    f = tmp_path / "jobs.toml"
    f.write_text(f'[[job]]\ndomain = "lamp.cp"\n{line}\n')
    code, out, err = run(["batch", str(f)], capsys)
    assert code == 2 and out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"cplus batch: error: {f}:") and message in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.toml", "lamp.cp"]


@given(st.sampled_from(["jobs", "gamma", "max_horizon", "n", "max_iterations"]),
       st.integers(-3, 2000) | st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from([10 ** 30, 1e300]))
@settings(max_examples=150)
def test_a_job_option_is_refused_exactly_when_the_flag_is(key, value):
    """Whatever the number: the job file takes it iff ``cplus plan``'s flag takes its text."""
    import argparse
    import tempfile

    from cplus.cli.plan import build_parser
    flag = {"jobs": "--jobs", "gamma": "--gamma", "max_horizon": "--max-horizon", "n": "-n",
            "max_iterations": "--max-iterations"}[key]
    action = next(a for a in build_parser()._actions if flag in a.option_strings)
    try:
        action.type(repr(value) if isinstance(value, float) else str(value))      # type: ignore[misc]
        flag_ok = True
    except argparse.ArgumentTypeError:
        flag_ok = False
    options = {key: value, **({"jobs": 2, "strategy": "B"} if key == "gamma" else {})}
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / "j.jsonl"
        f.write_text(json.dumps({"domain": str(LAMP), "options": options}) + "\n")
        try:
            read_jobs(str(f))
            job_ok = True
        except BatchError:
            job_ok = False
    assert job_ok == flag_ok, (key, value)


# ------------------------------------------------------------------------------------- results file


def test_a_corrupted_record_is_named_by_its_line_and_its_job_runs_again(tmp_path, capsys):
    f = jobs_file(tmp_path, [{"id": "a", "domain": str(LAMP), "query": "on"},
                             {"id": "b", "domain": str(LAMP), "query": "on"},
                             {"id": "c", "domain": str(LAMP), "query": "on"},
                             {"id": "d", "domain": str(LAMP), "query": "on"}])
    results = tmp_path / "jobs.results.jsonl"
    good = {"format": "cplus.batch/1", "id": "a", "status": "found", "maxstep": 1, "marker": "kept"}
    results.write_text("\n".join(json.dumps(r) for r in (
        good, dict(good, id="b", status=["found"]), dict(good, id="c", times={"wall_s": "fast"}),
        dict(good, id="d", status="finished"))) + "\n")
    code, _, err = run(["batch", str(f)], capsys)
    assert code == 0, err
    assert f"cplus batch: warning: {results}:2: job 'b': status [\"found\"] is not one of found," in err
    assert f"cplus batch: warning: {results}:3: job 'c': 'times' are not numbers of seconds; it runs again" in err
    assert f"cplus batch: warning: {results}:4: job 'd': status \"finished\" is not one of" in err
    assert "1 of 4 jobs done before; running the other 3" in err
    got = ResultsFile(str(results)).records()
    assert got["a"]["marker"] == "kept" and all(got[k]["status"] == "found" and "marker" not in got[k] for k in "bcd")
    code, _, err = run(["batch", str(f)], capsys)      # the bad lines are history now: no word about them
    assert code == 0 and "warning" not in err and "4 of 4 jobs done before" in err


def test_a_second_batch_on_one_results_file_is_refused_naming_the_first(tmp_path, capsys):
    f = jobs_file(tmp_path, [{"id": "a", "domain": str(LAMP), "query": "on"}])
    results = tmp_path / "jobs.results.jsonl"
    holder = subprocess.Popen([sys.executable, "-c", "import fcntl, sys\n"
                               f"f = open({str(results)!r}, 'a')\nfcntl.flock(f, fcntl.LOCK_EX)\n"
                               "print('locked', flush=True)\nsys.stdin.read()\n"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "locked\n"      # type: ignore[union-attr]
        code, _, err = run(["batch", str(f)], capsys)
    finally:
        holder.communicate("", timeout=30)
    assert code == 2 and err.startswith(f"cplus batch: error: --results {results}: another batch is writing it "
                                        f"(pid {holder.pid}: ")
    assert "wait for it to end, or give another --results" in err and results.read_text() == ""
    code, _, err = run(["batch", str(f), "--quiet"], capsys)
    assert code == 0 and set(ResultsFile(str(results)).records()) == {"a"}


def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (from /proc)."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as fh:
                    ppid = int(fh.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            children.setdefault(ppid, []).append(int(entry))
    out: set[int] = set()
    todo = [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            out.add(c)
            todo.append(c)
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.slow
def test_sigterm_ends_a_batch_like_ctrl_c_and_every_process_it_started(tmp_path):
    """SIGTERM while jobs run (one on two search workers, one racing two solvers): exit 143 with
    a word, what finished kept, and no process of the batch left: the pool's workers, the
    search's and the race's children, the fork server, the resource tracker."""
    never = tmp_path / "never.cp"
    never.write_text(":- constants lit :: inertialFluent; flip :: exogenousAction.\nflip causes lit.\n"
                     ":- query maxstep :: 0..infinity; 0: lit & -lit.\n")
    f = jobs_file(tmp_path, [{"id": "quick", "domain": str(LAMP), "query": "on"},
                             {"id": "search", "domain": str(never), "options": {"jobs": 2}},
                             {"id": "race", "domain": str(never), "portfolio": ["glucose4", "minisat22"]},
                             {"id": "endless", "domain": str(never)}])
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "batch", str(f), "--workers", "3"],
                            stderr=subprocess.PIPE, text=True, cwd=ROOT, start_new_session=True)
    try:
        seen = ""
        while "quick: found" not in seen:
            line = proc.stderr.readline()      # type: ignore[union-attr]
            assert line, seen
            seen += line
        started: set[int] = set()
        for _ in range(600):                   # the pool's workers, the search's two, the race's two
            started |= _descendants(proc.pid)
            if len(started) >= 9 or proc.poll() is not None:
                break
            time.sleep(0.1)
        proc.send_signal(signal.SIGTERM)
        err = ""
        _, err = proc.communicate(timeout=wall(60))
    except subprocess.TimeoutExpired:
        alive = sorted(p for p in started | _descendants(proc.pid) if _alive(p))
        err = (f"no exit within {wall(60):.0f} s of SIGTERM ({len(started)} processes seen started); "
               f"still alive: {alive}; stderr before the signal:\n{seen}")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 143 and "Traceback" not in err, err
    assert "cplus batch: stopped by SIGTERM: 1 of 4 jobs recorded" in err and "run the same command to resume" in err
    assert len(started) >= 9, started          # resource tracker, fork server, 3 workers, 2 + 2 below them
    for _ in range(100):                       # a killed process is reaped by init in its own time
        left = {p for p in started if _alive(p)}
        if not left:
            break
        time.sleep(0.1)
    assert not left, left


# ------------------------------------------------------------------------------------- Ray


@pytest.mark.slow
@pytest.mark.timeout(420)
def test_a_batch_on_a_local_ray_instance(tmp_path, monkeypatch):
    """The same jobs on Ray (a local instance, started and shut down by the batch): every job
    recorded, a lost worker retried by Ray, a portfolio's losers cancelled, a time limit."""
    if os.environ.get("CPLUS_REQUIRE_RAY"):
        import ray  # noqa: F401   # CI installs the extra: a missing Ray fails here instead of skipping
    pytest.importorskip("ray")
    # Ray's workers import the job function by name: this module's `killer` too, and with it
    # the tests' own `walltime` one folder up
    here = Path(__file__).resolve().parent
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in (str(here), str(here.parent),
                                                                  os.environ.get("PYTHONPATH")) if p))
    # a local instance is started even where RAY_ADDRESS names a cluster (nothing listens there)
    monkeypatch.setenv("RAY_ADDRESS", "127.0.0.1:1")
    (tmp_path / "lamp.cp").write_text(LAMP.read_text())
    f = jobs_file(tmp_path, [{"id": "victim", "domain": "lamp.cp", "query": "on"},
                             {"id": "ferry", "domain": str(FERRY), "portfolio": ["glucose4", "minisat22"]},
                             {"id": "slow", "domain": str(HANOI), "timeout": 0.5},
                             {"id": "lamp", "domain": "lamp.cp", "query": "on"},
                             {"id": "stuck", "domain": "lamp.cp", "query": "on", "timeout": 0.5}])
    from cplus.batch import run_ray
    from cplus.cli.batch_job import DEFINITE, variant
    out: list[dict] = []
    run_ray(read_jobs(str(f)), killer, 2, None, 1, out.append, Progress(5, quiet=True), variant, DEFINITE)
    got = {r["id"]: r for r in out}
    assert set(got) == {"victim", "ferry", "slow", "lamp", "stuck"} and len(out) == 5
    # cancelled by the time limit's backstop: recorded, not dropped
    assert got["stuck"]["status"] == "timeout" and "TaskCancelledError" in got["stuck"]["error"]
    assert got["victim"]["status"] == "found" and (tmp_path / "killed-once").exists()
    assert got["ferry"]["status"] == "found" and got["ferry"]["maxstep"] == 17
    assert got["ferry"]["portfolio"]["winner"] in ("glucose4", "minisat22")
    assert got["slow"]["status"] == "timeout"
    assert got["lamp"]["status"] == "found"


def test_a_cluster_that_refuses_the_token_is_named_in_one_line():
    from cplus.batch.engine import unreachable
    nested = RuntimeError("Failed to connect to GCS. Last connection error: Traceback (most recent call last):\n"
                          "  File \"x.py\", line 1\nray.exceptions.AuthenticationError: RPC error: InvalidAuthToken: "
                          "Authentication token is missing or incorrect. Note: RAY_AUTH_MODE is currently 'disabled'")
    try:
        raise ConnectionError("Failed to connect to Ray cluster at 10.0.0.1:6379") from nested
    except ConnectionError as exc:
        line = unreachable("head:6379", exc)
    assert line.startswith("--ray head:6379: cannot join the Ray cluster (ray.exceptions.AuthenticationError: ")
    assert "RAY_AUTH_MODE=token" in line and "\n" not in line
    plain = unreachable("head:6379", ConnectionError("Failed to connect to Ray cluster at 10.0.0.1:6379"))
    assert plain == "--ray head:6379: cannot join the Ray cluster (Failed to connect to Ray cluster at 10.0.0.1:6379)"


def test_a_batch_with_nothing_to_run_starts_no_ray(tmp_path, capsys, monkeypatch):
    """Every job already recorded: `--ray` neither starts an instance nor joins a cluster."""
    ray = pytest.importorskip("ray")
    f = jobs_file(tmp_path, [{"id": "a", "domain": str(LAMP), "query": "on"}])
    assert run(["batch", str(f), "--quiet"], capsys)[0] == 0
    before = (tmp_path / "jobs.results.jsonl").read_bytes()
    started: list = []
    monkeypatch.setattr(ray, "init", lambda *a, **k: started.append(k))
    code, out, err = run(["batch", str(f), "--ray", "--quiet"], capsys)
    assert code == 0 and started == [] and (tmp_path / "jobs.results.jsonl").read_bytes() == before


def test_a_local_ray_instance_that_does_not_start_is_one_line(tmp_path, capsys, monkeypatch):
    """Ray raises a bare Exception when its raylet misses its 30 s (a loaded machine): the batch
    says so in one line, exit 2, and records nothing as run."""
    ray = pytest.importorskip("ray")

    def timed_out(*a, **k):
        raise Exception("The current node timed out during startup. This could happen because some of the "
                        "raylet failed to startup or the GCS has become overloaded.")
    monkeypatch.setattr(ray, "init", timed_out)
    f = jobs_file(tmp_path, [{"id": "a", "domain": str(LAMP), "query": "on"}])
    code, out, err = run(["batch", str(f), "--ray", "--quiet"], capsys)
    assert code == 2 and "Traceback" not in err
    assert err == ("cplus batch: error: --ray: a local Ray instance did not start: The current node timed out "
                   "during startup. This could happen because some of the raylet failed to startup or the GCS has "
                   "become overloaded. (nothing was run; without --ray the jobs run in local processes)\n")
    assert not (tmp_path / "jobs.results.jsonl").exists() or records(tmp_path / "jobs.results.jsonl") == []


def _free_port() -> int:
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def ray_cluster():
    """A Ray cluster as `ray start --head` makes one (its own processes, its own temp folder,
    token authentication as Ray 2.5x enables it), reached only by its address; yields
    (address, environment of a client holding the token), and is killed with its process group."""
    if os.environ.get("CPLUS_REQUIRE_RAY"):
        import ray  # noqa: F401
    pytest.importorskip("ray")
    import secrets
    import selectors
    import shutil
    import tempfile
    import time
    temp = tempfile.mkdtemp(prefix="r", dir="/tmp")      # short: Ray's socket paths live under it
    port = _free_port()
    token = secrets.token_hex(32)
    # PYTHONUNBUFFERED: `ray start` writes to a pipe here, which Python would buffer, holding back
    # the line awaited below
    env = dict(os.environ, RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=token, RAY_USAGE_STATS_ENABLED="0", PYTHONUNBUFFERED="1",
               PYTHONPATH=os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p))
    env.pop("RAY_ADDRESS", None)
    head = subprocess.Popen([sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--block",
                             f"--port={port}", "--num-cpus=2", "--include-dashboard=false", "--disable-usage-stats",
                             f"--temp-dir={temp}"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        sel = selectors.DefaultSelector()
        sel.register(head.stdout, selectors.EVENT_READ)
        seen = ""
        limit = time.monotonic() + wall(300)       # a bound on failure only: the event awaited is Ray's line
        while "Ray runtime started" not in seen:
            assert time.monotonic() < limit and head.poll() is None, f"ray start ({head.poll()}): " + seen[-3000:]
            if sel.select(timeout=1):
                # what the pipe holds, unbuffered: a readline() would leave the rest of a chunk in
                # the file's buffer, where select() cannot see it
                seen += os.read(head.stdout.fileno(), 65536).decode(errors="replace")
        sel.close()
        yield f"127.0.0.1:{port}", env
    finally:
        try:
            os.killpg(head.pid, signal.SIGTERM)
            head.wait(timeout=wall(30))
        except (ProcessLookupError, subprocess.TimeoutExpired):
            pass
        try:
            os.killpg(head.pid, signal.SIGKILL)   # what SIGTERM left of the group (raylet, workers)
        except ProcessLookupError:
            pass
        head.stdout.close()
        shutil.rmtree(temp, ignore_errors=True)


@pytest.mark.slow
@pytest.mark.timeout(420)
def test_a_batch_on_a_ray_cluster_at_its_address(tmp_path, ray_cluster):
    """`--ray ADDRESS` joins an existing cluster (started apart, as on a head node) and runs every
    job there; a client without the cluster's token gets one line that says what is missing."""
    address, env = ray_cluster
    f = jobs_file(tmp_path, [{"id": "ferry", "domain": str(FERRY)}, {"id": "lamp", "domain": str(LAMP), "query": "on"}])
    cmd = [sys.executable, "-m", "cplus", "batch", str(f), f"--ray={address}", "--quiet"]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env, timeout=wall(300))
    assert done.returncode == 0, done.stderr
    got = {r["id"]: r for r in records(tmp_path / "jobs.results.jsonl")}
    assert got["ferry"]["status"] == "found" and got["ferry"]["maxstep"] == 17
    assert got["lamp"]["status"] == "found"
    wrong = dict(env, RAY_AUTH_TOKEN="0" * 64)
    refused = subprocess.run([*cmd, "--fresh"], capture_output=True, text=True, cwd=ROOT, env=wrong, timeout=300)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    line = [x for x in refused.stderr.splitlines() if x.startswith("cplus batch:")]
    assert len(line) == 1 and f"--ray {address}: cannot join the Ray cluster" in line[0]
    assert "RAY_AUTH_MODE=token" in line[0]
