"""``cplus batch JOBS``: many ``cplus plan`` jobs on a local process pool, or on Ray.

JOBS is a TOML or JSON-lines job file or a folder of domains (:mod:`cplus.batch.jobs`).  Each
job's record is appended to the results file as the job ends (``cplus.batch/1``, one JSON line
per job); a batch run again with the same results file skips the jobs it already has
(``--redo`` names statuses to run again), so an interrupted or crashed batch resumes.  At the
end: the CSV summary beside the results and a table of statuses on stderr.

Exit codes: 0 every job ran to a planner's answer (found, no plan, ...); 1 some job ended in
``error``, ``timeout``, ``memory`` or ``lost``; 2 bad input (the job file, an option, ``--ray``
without Ray); 130 interrupted (the results so far are kept: run the same command to resume).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

from cplus.cli.batch_job import PLAN_STATUSES
from cplus.cli.common import EXIT_INPUT, EXIT_NO_PLAN, EXIT_OK, OneLineArgumentParser, nonneg, positive, positive_int

__all__ = ["build_parser", "main"]


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog="cplus batch", description="Run many planning jobs on a process pool or on Ray.")
    p.add_argument("jobs", metavar="JOBS", help="a job file (.toml, or JSON lines) or a folder of domains")
    p.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                   help="run on Ray: a local instance (no ADDRESS), or the cluster at ADDRESS (e.g. ray://head:10001 "
                        "or auto); put it after JOBS, or write --ray=ADDRESS")
    p.add_argument("--workers", type=positive_int, default=None, metavar="N",
                   help="worker processes (default: the cores there are; a Ray cluster: its CPUs)")
    p.add_argument("--results", metavar="FILE", help="the results file (default: JOBS with .results.jsonl)")
    p.add_argument("--csv", metavar="FILE", help="the CSV summary (default: the results file with .csv)")
    p.add_argument("--fresh", action="store_true", help="start the results file anew instead of resuming from it")
    p.add_argument("--redo", metavar="STATUSES", default="",
                   help="run again the jobs whose recorded status is one of these (e.g. timeout,memory,lost)")
    p.add_argument("--timeout", type=positive, default=None, metavar="SECONDS",
                   help="each job's time limit unless the job file gives one")
    p.add_argument("--memory", type=positive_int, default=None, metavar="MB",
                   help="each job's memory limit unless the job file gives one")
    p.add_argument("--retries", type=nonneg, default=2, metavar="N",
                   help="submit a job again up to N times when its worker is lost (default 2)")
    p.add_argument("--portfolio", metavar="LIST", default=None,
                   help="race these solvers (or strategies sequential, A, B) on each job, e.g. "
                        "glucose4,cadical195,minisat22; the first answer wins, the others are cancelled")
    p.add_argument("--solver", metavar="NAME", default=None, help="each job's solver unless the job file gives one")
    p.add_argument("--plans", action="store_true", help="keep every job's plans in its record")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr, no table at the end")
    return p


STATUSES = (*PLAN_STATUSES, "error", "timeout", "memory", "lost")


def main(args: argparse.Namespace) -> int:
    from cplus.batch import FAILED, BatchError, Progress, ResultsFile, read_jobs, run_local, run_ray, write_csv
    from cplus.cli.batch_job import DEFINITE, run_job, variant, worker_init
    from cplus.parallel import available_cores
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
        defaults["portfolio"] = [p for p in args.portfolio.split(",") if p]
    jobs = read_jobs(args.jobs, defaults)
    _check_names(jobs)
    if args.ray is not None:
        try:
            import ray  # noqa: F401
        except ImportError:
            from cplus.batch import RAY_MISSING
            raise BatchError(RAY_MISSING) from None
    stem = os.path.splitext(args.jobs.rstrip("/"))[0]
    results_path = args.results or stem + ".results.jsonl"
    csv_path = args.csv or os.path.splitext(results_path)[0] + ".csv"
    results = ResultsFile(results_path)
    have = {} if args.fresh else results.records()
    todo = [j for j in jobs if j.id not in have or have[j.id]["status"] in redo]
    try:
        results.open(fresh=args.fresh)
    except OSError as exc:
        raise BatchError(f"{results_path}: cannot be written ({exc.strerror})") from None
    records = dict(have)
    workers = args.workers or available_cores()
    progress = Progress(len(jobs), len(jobs) - len(todo), quiet=args.quiet)
    if not args.quiet and have:
        print(f"% {results_path}: {len(jobs) - len(todo)} of {len(jobs)} jobs done before; running the other "
              f"{len(todo)}", file=sys.stderr)

    def sink(record: dict) -> None:
        results.append(record)
        records[record["id"]] = record

    t0 = time.perf_counter()
    interrupted = False
    try:
        if args.ray is None:
            run_local(todo, run_job, workers, args.retries, sink, progress, worker_init)
        else:
            run_ray(todo, run_job, args.workers, None if args.ray == "local" else args.ray, args.retries, sink,
                    progress, variant, DEFINITE)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        progress.close()
        results.close()
        ordered = [records[j.id] for j in jobs if j.id in records]
        write_csv(csv_path, ordered)
    if not args.quiet:
        _table(ordered, len(jobs), time.perf_counter() - t0, results_path, csv_path)
    if interrupted:
        print(f"cplus batch: interrupted: {len(ordered)} of {len(jobs)} jobs recorded in {results_path}; "
              "run the same command to resume", file=sys.stderr)
        return 130
    failed = any(r["status"] in FAILED for r in ordered)
    return EXIT_NO_PLAN if failed else EXIT_OK


def _check_names(jobs) -> None:
    """A portfolio entry or a solver that no job could run is refused before anything runs."""
    from cplus.batch import BatchError
    from cplus.sat.solver import solver_names
    names = set(solver_names())
    for j in jobs:
        for n in [*j.portfolio, *([j.solver] if j.solver else [])]:
            if n not in names and n not in ("sequential", "A", "B"):
                raise BatchError(f"job {j.id}: unknown solver or strategy '{n}' "
                                 f"(solvers: {', '.join(sorted(names))}; strategies: sequential, A, B)")


def _table(records: list[dict], total: int, wall: float, results_path: str, csv_path: str) -> None:
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
