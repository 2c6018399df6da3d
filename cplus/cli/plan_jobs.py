"""``cplus plan --jobs``: the options' checks, the call into :mod:`cplus.parallel`, and the
per-worker ``--stats`` lines.  A module of its own so that ``cplus plan`` without ``--jobs``
imports none of it (nor ``multiprocessing``)."""
from __future__ import annotations

import argparse
import sys

from cplus.cli.common import clear_progress, horizon_progress

__all__ = ["check_options", "solve", "refine_on_jobs", "record_line"]


def check_options(args: argparse.Namespace) -> str | None:
    """What does not go together, as the one-line usage error to print (None: all is well)."""
    if args.gamma is not None and args.strategy != "B":    # asked for by name, even now that B is the default
        return "cplus plan: error: --gamma applies to --strategy B"
    if args.no_refine:
        print("cplus plan: warning: --no-refine checks one plan in this process; --jobs ignored", file=sys.stderr)
    return None


def _options(args: argparse.Namespace) -> dict:
    from cplus.parallel import DEFAULT_GAMMA
    from cplus.parallel.strategy import DEFAULT_STRATEGY
    return {"jobs": args.jobs, "strategy": args.strategy or DEFAULT_STRATEGY,
            "gamma": args.gamma if args.gamma is not None else DEFAULT_GAMMA, "any_length": args.any_length}


def record_line(r: dict) -> str:
    """A ``--stats`` line for one worker's run of one horizon."""
    verdict = {"sat": "solution", "unsat": "no solution", "dropped": "cancelled (a shorter plan was found)",
               "taken": "taken over (by the worker of the shortest unfinished horizon)",
               "stopped": "stopped (not needed)"}.get(r["result"], str(r["result"]))
    return (f"% worker {r['worker']}, maxstep {r['maxstep']}: {r['variables']} variables, {r['clauses']} clauses, "
            f"encode {r['encode_s']:.3f} s, solve {r['solve_s']:.3f} s (processor {r['cpu_s']:.3f} s in all, "
            f"{r['slices']} slices): {verdict}")


def _on_record(args: argparse.Namespace):
    tty = sys.stderr.isatty()

    def on_record(r: dict) -> None:
        if args.stats:
            print(record_line(r), file=sys.stderr)
        elif tty and r["result"] == "unsat":
            print(f"\r% maxstep {r['maxstep']} ...", end="", file=sys.stderr, flush=True)
    return on_record


def _not_shortest(result) -> None:
    info = result.parallel
    if not info["proved_shortest"]:
        open_ = ", ".join(map(str, info["not_proved_empty"]))
        print(f"% maxstep {result.maxstep}: the first plan found (--any-length), not proved shortest: "
              f"maxstep {open_} not proved empty", file=sys.stderr)


def solve(domain, label: str, solutions: int, args: argparse.Namespace):
    """The query on ``--jobs`` workers: a :class:`cplus.parallel.ParallelResult`."""
    from cplus.parallel import solve_parallel
    from cplus.sat.solver import DEFAULT_SOLVER
    result = solve_parallel(domain, label, solutions, args.solver or DEFAULT_SOLVER, args.max_horizon,
                            on_record=_on_record(args), on_horizon=horizon_progress(args.stats), **_options(args))
    clear_progress(args.stats)
    if args.stats:
        info = result.parallel
        where = f" from maxstep {info['parallel_from']}" if info["parallel_from"] is not None else ""
        ran = "in this process (every horizon was easy)" if not info["runs"] and args.jobs == "auto" else \
            f"on {info['jobs']} workers{where}, strategy {info['strategy']}"
        print(f"% searched {ran}; {info['workers_replaced']} workers replaced", file=sys.stderr)
    if result.maxstep is not None:
        _not_shortest(result)
    return result


def refine_on_jobs(task, label: str, args: argparse.Namespace, options: dict):
    """A robot task's refinement on ``--jobs`` workers."""
    from cplus.robot import refine_parallel
    options = dict(options, on_record=_on_record(args), **_options(args))
    if args.strategy is None:       # robot tasks keep A (B is the default measured on plain planning only)
        options["strategy"] = "A"
    result = refine_parallel(task, label, args.max_iterations, args.max_horizon, args.solver, **options)
    clear_progress(args.stats)
    if result.history is not None:
        _not_shortest(result)
    return result
