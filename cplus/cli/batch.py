"""``cplus batch JOBS``: many ``cplus plan`` jobs on a local process pool, or on Ray.

JOBS is a TOML or JSON-lines job file or a folder of domains (:mod:`cplus.batch.jobs`).  Each
job's record is appended to the results file as the job ends (``cplus.batch/1``, one JSON line
per job); a batch run again with the same results file skips the jobs it already has
(``--redo`` names statuses to run again), so an interrupted or crashed batch resumes.  At the
end: the CSV summary beside the results and a table of statuses on stderr.

Exit codes: 0 every job ran to a planner's answer (found, no plan, ...); 1 some job ended in
``error``, ``timeout``, ``memory`` or ``lost``; 2 bad input (the job file, an option, a path,
``--ray`` without Ray, another batch writing the results file); 130 interrupted, 143 SIGTERM
(the results so far are kept: run the same command to resume).
"""
from __future__ import annotations

import argparse
import os
import sys
import threading
import time
from contextlib import contextmanager

from cplus.cli.common import EXIT_INPUT, EXIT_NO_PLAN, EXIT_OK, OneLineArgumentParser, checked, nonempty, nonneg
from cplus.cli.paths import Input, Output, check_paths
from cplus.options import (
    WORKERS_PER_CORE,
    available_cores,
    check_jobs,
    check_memory,
    check_portfolio,
    check_solver,
    check_timeout,
    worker_bound,
)

__all__ = ["build_parser", "main"]


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog="cplus batch", description="Run many planning jobs on a process pool or on Ray.")
    p.add_argument("jobs", metavar="JOBS", type=nonempty,
                   help="a job file (.toml, or JSON lines) or a folder of domains")
    p.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                   help="run on Ray: a local instance (no ADDRESS), or the cluster at ADDRESS (e.g. ray://head:10001 "
                        "or auto); put it after JOBS, or write --ray=ADDRESS")
    p.add_argument("--workers", type=checked(_workers, int), default=None, metavar="N",
                   help=f"worker processes (default: the cores there are; a Ray cluster: its CPUs); no more start "
                        f"than there are jobs to run, nor {WORKERS_PER_CORE} per core")
    p.add_argument("--results", type=nonempty, metavar="FILE",
                   help="the results file (default: JOBS with .results.jsonl)")
    p.add_argument("--csv", type=nonempty, metavar="FILE",
                   help="the CSV summary (default: the results file with .csv)")
    p.add_argument("--fresh", action="store_true", help="start the results file anew instead of resuming from it")
    p.add_argument("--redo", metavar="STATUSES", default="",
                   help="run again the jobs whose recorded status is one of these (e.g. timeout,memory,lost)")
    p.add_argument("--timeout", type=checked(check_timeout, float), default=None, metavar="SECONDS",
                   help="each job's time limit unless the job file gives one")
    p.add_argument("--memory", type=checked(check_memory, int), default=None, metavar="MB",
                   help="each job's memory limit unless the job file gives one")
    p.add_argument("--retries", type=nonneg, default=2, metavar="N",
                   help="submit a job again up to N times when its worker is lost (default 2)")
    p.add_argument("--portfolio", metavar="LIST", type=checked(_portfolio), default=None,
                   help="race these solvers (or strategies sequential, A, B) on each job, e.g. "
                        "glucose4,cadical195,minisat22; the first answer wins, the others are cancelled")
    p.add_argument("--solver", metavar="NAME", type=checked(check_solver), default=None,
                   help="each job's solver unless the job file gives one")
    p.add_argument("--plans", action="store_true", help="keep every job's plans in its record")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr, no table at the end")
    return p


def _workers(value: object) -> int:
    """``--workers``: bounded as ``--jobs`` is (no ``auto``: the default is the cores)."""
    if value == "auto":
        from cplus.options import OptionError
        raise OptionError("expected a positive integer (leave --workers out for the cores there are)")
    return check_jobs(value)  # type: ignore[return-value]


def _portfolio(text: object) -> list[str]:
    return check_portfolio(str(text).split(","))


def main(args: argparse.Namespace) -> int:
    from cplus.batch import BatchError, read_jobs
    from cplus.batch.results import STATUSES
    redo = {s for s in args.redo.split(",") if s}
    bad = sorted(redo - set(STATUSES))
    if bad:
        print(f"cplus batch: error: --redo: unknown status '{bad[0]}' (statuses: {', '.join(STATUSES)})",
              file=sys.stderr)
        return EXIT_INPUT
    defaults: dict = {}
    for key, value in (("timeout", args.timeout), ("memory", args.memory), ("solver", args.solver)):
        if value is not None:
            defaults[key] = value
    if args.plans:
        defaults["plans"] = True
    if args.portfolio is not None:
        defaults["portfolio"] = args.portfolio
    jobs = read_jobs(args.jobs, defaults)
    if args.ray is not None:
        try:
            import ray  # noqa: F401
        except ImportError:
            from cplus.batch import RAY_MISSING
            raise BatchError(RAY_MISSING) from None
    stem = os.path.splitext(args.jobs.rstrip("/"))[0]
    results_path = args.results or stem + ".results.jsonl"
    csv_path = args.csv or os.path.splitext(results_path)[0] + ".csv"
    check_paths("cplus batch", _inputs(args.jobs, jobs),
                [Output("--results" if args.results else "--results (default)", results_path),
                 Output("--csv" if args.csv else "--csv (default)", csv_path)])
    with _terminated_as_interrupt():
        return _run(args, jobs, redo, results_path, csv_path)


def _inputs(path: str, jobs) -> list[Input]:
    """What a batch reads: the job file and every job's domain, scene and externals."""
    out = [Input(path, "the job file")]
    for j in jobs:
        out += [Input(j.domain, f"the domain of job {j.id}"), Input(j.scene, f"the scene of job {j.id}"),
                *(Input(x, f"an extern file of job {j.id}") for x in j.options.get("extern", []))]
    return out


def _run(args: argparse.Namespace, jobs, redo: set[str], results_path: str, csv_path: str) -> int:
    from cplus.batch import FAILED, BatchError, Progress, ResultsFile, run_local, run_ray, write_csv
    from cplus.batch.results import ResultsBusy
    from cplus.cli.batch_job import DEFINITE, run_job, variant, worker_init
    from cplus.cli.signals import exit_code_of, reason_of
    results = ResultsFile(results_path)
    try:
        results.open(fresh=args.fresh)
    except ResultsBusy as exc:
        raise BatchError(f"--results {results_path}: another batch is writing it"
                         + (f" ({exc.holder})" if exc.holder else "")
                         + "; wait for it to end, or give another --results") from None
    except OSError as exc:
        raise BatchError(f"--results {results_path}: cannot be written ({exc.strerror})") from None
    try:
        have = {} if args.fresh else results.records()
        for problem in results.problems:
            print(f"cplus batch: warning: {problem}", file=sys.stderr)
        todo = [j for j in jobs if j.id not in have or have[j.id]["status"] in redo]
        records = dict(have)
        workers = worker_bound(args.workers or available_cores(), len(todo))
        progress = Progress(len(jobs), len(jobs) - len(todo), quiet=args.quiet)
        if not args.quiet and have:
            print(f"% {results_path}: {len(jobs) - len(todo)} of {len(jobs)} jobs done before; running the other "
                  f"{len(todo)}", file=sys.stderr)

        def sink(record: dict) -> None:
            results.append(record)
            records[record["id"]] = record

        t0 = time.perf_counter()
        stopped: KeyboardInterrupt | None = None
        try:
            if args.ray is None:
                run_local(todo, run_job, workers, args.retries, sink, progress, worker_init)
            else:
                run_ray(todo, run_job, workers, None if args.ray == "local" else args.ray, args.retries, sink,
                        progress, variant, DEFINITE)
        except KeyboardInterrupt as exc:
            stopped = exc
        finally:
            progress.close()
            ordered = [records[j.id] for j in jobs if j.id in records]
            try:
                write_csv(csv_path, ordered)
            except OSError as exc:
                print(f"cplus batch: error: --csv {csv_path}: cannot write: {exc.strerror or exc}", file=sys.stderr)
    finally:
        results.close()
    if not args.quiet:
        _table(ordered, len(jobs), time.perf_counter() - t0, results_path, csv_path)
    if stopped is not None:
        print(f"cplus batch: {reason_of(stopped)}: {len(ordered)} of {len(jobs)} jobs recorded in {results_path}; "
              "run the same command to resume", file=sys.stderr)
        return exit_code_of(stopped)
    failed = any(r["status"] in FAILED for r in ordered)
    return EXIT_NO_PLAN if failed else EXIT_OK


@contextmanager
def _terminated_as_interrupt():
    """SIGTERM ends a batch as Ctrl-C does (the jobs in flight stopped, their processes and
    the pool's fork server ended, what is done kept), then exits 143."""
    import signal

    from cplus.cli.signals import Stopped
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum, frame) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)      # the cleanup that follows is not cut short
        raise Stopped(signum)
    old = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _table(records: list[dict], total: int, wall: float, results_path: str, csv_path: str) -> None:
    from cplus.batch.results import STATUSES
    counts: dict[str, int] = {}
    for r in records:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    out = sys.stderr
    print(f"% batch: {len(records)} of {total} jobs recorded, {wall:.1f} s this run", file=out)
    print("% status           jobs", file=out)
    for status in STATUSES:
        if status in counts:
            print(f"% {status:<15} {counts[status]:>5}", file=out)
    slow = sorted((r for r in records if (r.get("times") or {}).get("wall_s") is not None),
                  key=lambda r: -r["times"]["wall_s"])[:5]
    if slow:
        print("% slowest: " + ", ".join(f"{r['id']} {r['times']['wall_s']:.2f} s" for r in slow), file=out)
    print(f"% results: {results_path}; summary: {csv_path}", file=out)
