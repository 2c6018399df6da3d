"""One batch job, run inside a worker (a pool process or a Ray worker): :func:`run_job`.

It does what ``cplus plan`` does for the job's file (a robot task when it has a scene),
through the API rather than a new interpreter, under the job's time and memory limits
(:mod:`cplus.batch.limits`), and returns its ``cplus.batch/1`` record (README) instead of
printing.  Whatever goes wrong becomes the record's status: ``error`` (the located one-line
message ``cplus plan`` would print), ``timeout``, ``memory``.  Here because a robot task's
refinement is the robot stack's, which :mod:`cplus.batch` may not import.
"""
from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING, Any

from cplus.batch.results import PLAN_STATUSES

if TYPE_CHECKING:
    from cplus.planner import QueryResult

__all__ = ["run_job", "race", "variant", "worker_init", "DEFINITE"]

DEFINITE = ("found", "no_plan", "no_plan_proved", "horizon_limit", "invariant_wrong", "no_safe_plan", "unsafe")
"""Statuses that answer a job: the first of them ends a portfolio race."""


def variant(job: dict, name: str) -> dict:
    """The job with one portfolio entry applied: a strategy (``sequential``, ``A``, ``B``,
    on ``options.jobs`` workers, 2 unless given) or a solver name."""
    if name in ("sequential", "A", "B"):
        options = dict(job["options"], strategy=name, jobs=job["options"].get("jobs", 2))
        return dict(job, options=options, portfolio=[])
    return dict(job, solver=name, portfolio=[])


def run_job(job: dict, attempt: int = 1) -> dict:
    """Run a job (:meth:`cplus.batch.Job.to_dict`) and return its record; with a portfolio,
    race its variants here (:func:`race`)."""
    import gc
    if job.get("portfolio"):
        return race(job, attempt)
    gc.disable()      # a planning job creates almost no cycles (as the command does); collected after
    try:
        return _run_job(job, attempt)
    finally:
        gc.enable()
        gc.collect()


def race(job: dict, attempt: int = 1) -> dict:
    """Run the portfolio variants of a job in child processes, as many at once as
    :func:`cplus.options.worker_bound` allows (the rest start as earlier ones end without an
    answer); the first whose status answers the job wins and the others are killed (SIGTERM
    ends a solver at once).  The job's time limit bounds the whole race; each variant has its
    memory limit."""
    import multiprocessing
    from collections import deque
    from multiprocessing.connection import wait

    from cplus.batch.limits import Deadline
    from cplus.options import worker_bound
    ctx = multiprocessing.get_context("fork")
    names = list(job["portfolio"])
    waiting = deque(names)
    at_once = worker_bound(len(names), len(names))
    procs: list = []
    pending: dict[Any, tuple[str, Any]] = {}

    def start() -> None:
        name = waiting.popleft()
        recv, send = ctx.Pipe(duplex=False)
        p = ctx.Process(target=_variant_main, args=(send, variant(dict(job, timeout=None), name), attempt),
                        daemon=True)
        p.start()
        send.close()
        procs.append((name, p, recv))
        pending[recv] = (name, p)
    t0 = time.perf_counter()
    records: dict[str, dict] = {}
    winner = None
    deadline = Deadline(job["timeout"])
    try:
        with deadline:
            while waiting and len(pending) < at_once:
                start()
            while pending and winner is None:
                for r in wait(list(pending)):
                    name, p = pending.pop(r)
                    try:
                        rec: dict = r.recv()       # type: ignore[union-attr,call-arg,assignment]
                    except EOFError:
                        rec = {"status": "lost", "error": f"the variant's process died (exit code {p.exitcode})"}
                    records[name] = rec
                    if rec.get("status") in DEFINITE:
                        winner = name
                        break
                    if waiting:
                        start()
    except KeyboardInterrupt:
        if not deadline.expired:
            raise
    finally:
        for _, p, recv in procs:
            if p.is_alive():
                p.terminate()
            p.join(5)
            recv.close()
    if winner is None:
        if records:
            winner = next(iter(records))
        else:
            rec = _empty(job, attempt)
            rec.update(status="timeout", error=f"over its time limit of {job['timeout']:g} s (portfolio)",
                       times={"wall_s": round(time.perf_counter() - t0, 6)})
            rec["portfolio"] = {"winner": None, "variants": names, "finished": {}}
            return rec
    rec = dict(records[winner])
    rec["id"], rec["solver"], rec["options"] = job["id"], job["solver"], job["options"]
    rec["portfolio"] = {"winner": winner, "variants": names,
                        "finished": {n: r.get("status") for n, r in records.items()}}
    rec["times"] = dict(rec.get("times", {}), race_wall_s=round(time.perf_counter() - t0, 6))
    return rec


def _variant_main(conn, job: dict, attempt: int) -> None:
    import signal

    from cplus.parallel.worker import die_with_parent
    die_with_parent()           # its job's worker killed (a pool ended by Ctrl-C or SIGTERM): this ends too
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        conn.send(run_job(job, attempt))
    except BaseException:     # Ctrl-C reaches the whole group: the parent reports it
        pass
    os._exit(0)


def _empty(job: dict, attempt: int) -> dict:
    from cplus.batch.limits import pid_host
    return {"format": "cplus.batch/1", "id": job["id"], "domain": job["domain"], "query": job["query"],
            "scene": job["scene"], "solver": job["solver"], "options": job["options"], "status": None,
            "maxstep": None, "results": [], "times": {}, "stats": {}, "error": None,
            "worker": pid_host(), "attempts": attempt}


def _run_job(job: dict, attempt: int) -> dict:
    from cplus.batch.limits import Deadline, MemoryLimit
    from cplus.errors import CPlusError
    t0, c0 = time.perf_counter(), time.process_time()
    record = _empty(job, attempt)
    timings = {"load_s": 0.0, "ground_s": 0.0, "encode_s": 0.0, "solve_s": 0.0}
    from cplus.sat.solver import solver_names
    solver_names()      # the solvers' library mapped before the memory limit: it counts for every job alike
    deadline = Deadline(job["timeout"])
    try:
        with deadline, MemoryLimit(job["memory"]):
            _run(job, record, timings)
    except KeyboardInterrupt:
        if not deadline.expired:
            raise
        record["status"] = "timeout"
        record["error"] = f"over its time limit of {job['timeout']:g} s"
    except MemoryError:
        record["status"] = "memory"
        record["error"] = f"over its memory limit of {job['memory']} MB" if job["memory"] else "out of memory"
    except CPlusError as exc:
        text = exc.render()
        memory = "more than the" in text and "this run may use" in text
        record["status"] = "memory" if memory and job["memory"] else "error"
        record["error"] = text
    except RecursionError:
        record["status"] = "error"
        record["error"] = "the input is nested too deeply to be processed"
    statuses = [r["status"] for r in record["results"]]
    if record["status"] is None:
        record["status"] = max(statuses, key=PLAN_STATUSES.index) if statuses else "error"
    found = [r["maxstep"] for r in record["results"] if r["maxstep"] is not None]
    record["maxstep"] = found[0] if len(record["results"]) == 1 and found else None
    timings.update(wall_s=time.perf_counter() - t0, cpu_s=time.process_time() - c0)
    record["times"] = {k: round(v, 6) for k, v in timings.items()}
    record["stats"] = {"horizons": sum(r["horizons"] for r in record["results"]),
                       "variables": max((r["variables"] for r in record["results"]), default=0),
                       "clauses": max((r["clauses"] for r in record["results"]), default=0)}
    record["finished"] = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    return record


def _run(job: dict, record: dict, timings: dict) -> None:
    from cplus.cli.common import externals, scene_beside
    opts = job["options"]
    scene = job["scene"] or scene_beside(job["domain"])
    t = time.perf_counter()
    if scene is not None:
        _robot(job, scene, record, timings, t)
        return
    from cplus.api import Domain
    from cplus.output import history_json
    from cplus.sat.solver import DEFAULT_SOLVER
    domain = Domain.load(job["domain"], externals(opts.get("extern", [])))
    timings["load_s"] += time.perf_counter() - t
    labels = [job["query"]] if job["query"] is not None else domain.labels
    if not labels:
        from cplus.errors import QueryError
        raise QueryError("this file has no queries; use 'query = \"states\"' to list its states")
    nm = bool(job.get("nmquery"))
    for label in labels:
        q = domain.spec(label, nm)
        if q.invariant is not None and not nm:
            _prove(domain, label, job["solver"], record, timings)
            continue
        t = time.perf_counter()
        domain.theory_for(q)
        timings["ground_s"] += time.perf_counter() - t
        every_state = label == "states" and q.loc is None
        n = opts.get("n", 0 if every_state else 1)
        solver = job["solver"] or DEFAULT_SOLVER
        result: QueryResult
        if nm:                  # its own completion, solved in this process (as cplus plan does)
            result = domain.solve(label, n, solver, opts.get("max_horizon"), nmquery=True)
        elif opts.get("jobs") is not None:
            from cplus.parallel import DEFAULT_GAMMA, solve_parallel
            from cplus.parallel.strategy import DEFAULT_STRATEGY
            result = solve_parallel(domain, label, n, solver, opts.get("max_horizon"), jobs=opts["jobs"],
                                    strategy=opts.get("strategy", DEFAULT_STRATEGY), gamma=opts.get("gamma", DEFAULT_GAMMA),
                                    any_length=opts.get("any_length", False))
        else:
            result = domain.solve(label, n, solver, opts.get("max_horizon"))
        timings["encode_s"] += sum(s.encode_s for s in result.stats)
        timings["solve_s"] += sum(s.solve_s for s in result.stats)
        last = result.stats[-1] if result.stats else None
        entry = {"query": label, "status": result.status.value, "maxstep": result.maxstep,
                 "no_solution_with_maxstep": list(result.failed), "horizons": len(result.stats),
                 "variables": last.variables if last else 0, "clauses": last.clauses if last else 0,
                 "histories": len(result.histories)}
        if job["plans"]:
            entry["plans"] = [history_json(h) for h in result.histories]
        record["results"].append(entry)


def _robot(job: dict, scene: str, record: dict, timings: dict, t: float) -> None:
    from cplus.robot import RobotTask, refine, refine_parallel
    opts = job["options"]
    task = RobotTask.load(job["domain"], scene, opts.get("extern", []))
    domain = task.domain
    timings["load_s"] += time.perf_counter() - t
    t = time.perf_counter()
    _ = domain.theory  # type: ignore[attr-defined]   # ground now, to time it apart
    timings["ground_s"] += time.perf_counter() - t
    labels = [job["query"]] if job["query"] is not None else domain.labels  # type: ignore[attr-defined]
    eager = {"auto": None, "yes": True, "no": False}[opts.get("eager", "auto")]
    for label in labels:
        if domain.query(label).invariant is not None:  # type: ignore[attr-defined]
            _prove(domain, label, job["solver"], record, timings)
            continue
        kw = dict(nogoods=opts.get("nogoods", "positions"), eager=eager)
        if opts.get("jobs") is not None:
            result = refine_parallel(task, label, opts.get("max_iterations", 0), opts.get("max_horizon"),
                                     job["solver"], jobs=opts["jobs"], strategy=opts.get("strategy", "A"),
                                     any_length=opts.get("any_length", False), **kw)
        else:
            result = refine(task, label, opts.get("max_iterations", 0), opts.get("max_horizon"), job["solver"], **kw)
        timings["encode_s"] += sum(s.encode_s for s in result.stats)
        timings["solve_s"] += sum(s.solve_s for s in result.stats)
        last = result.stats[-1] if result.stats else None
        entry = {"query": label, "status": result.status.value,
                 "maxstep": result.history.maxstep if result.history else None,
                 "no_solution_with_maxstep": list(result.no_solution_with_maxstep), "horizons": len(result.stats),
                 "variables": last.variables if last else 0, "clauses": last.clauses if last else 0,
                 "iterations": len(result.iterations), "nogoods": result.learned, "reason": result.reason or None}
        if job["plans"] and result.history is not None:
            from cplus.output import history_json
            entry["plans"] = [history_json(result.history)]
        record["results"].append(entry)


def _prove(domain: Any, label: str, solver: str | None, record: dict, timings: dict) -> None:
    """A ``maxstep :: any`` query is proved, not searched, as ``cplus plan`` does it: its
    entry has the proof's status and no horizons."""
    t = time.perf_counter()
    proof = domain.prove(label, solver)
    timings["solve_s"] += time.perf_counter() - t
    record["results"].append({"query": label, "status": proof.status.value, "maxstep": None,
                              "no_solution_with_maxstep": [], "horizons": 0, "variables": 0, "clauses": 0,
                              "histories": 0})


def worker_init() -> None:
    """A pool worker: one BLAS thread, as the ``cplus`` command asks (numpy's OpenBLAS
    otherwise starts a spinning thread per core in every worker); and what is loaded so far
    (the planner's modules) moved out of the cyclic collector's sight, so that the collection
    after each job looks at that job's objects only."""
    import gc
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    gc.freeze()
