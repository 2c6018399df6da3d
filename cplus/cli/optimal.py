"""``cplus plan``'s glue for proofs (``maxstep :: any``) and cost-optimal plans
(``--minimize``): options checked before any query runs, results printed, exit codes.

The library modules (:mod:`cplus.invariant`, :mod:`cplus.sat.optimize`) know nothing of the
command line; this module is imported only when a query has an invariant or ``--minimize``
is given, so planning's start-up does not pay for either.
"""
from __future__ import annotations

import sys

from cplus.cli.common import EXIT_INTERRUPTED, EXIT_INVARIANT_WRONG, EXIT_NO_PLAN_PROVED, EXIT_NOT_PROVED, EXIT_OK
from cplus.errors import CPlusError
from cplus.invariant import InvariantResult, InvariantStatus
from cplus.sat.optimize import Objective, Optimum, line, optimum_text, run_optimal

__all__ = ["proof_exit_code", "cli_check", "cli_solve", "robot_check", "robot_report"]


def proof_exit_code(result: InvariantResult) -> int:
    """The exit code of a proof (the README's table): 10 proved, 11 the invariant is wrong."""
    return EXIT_NO_PLAN_PROVED if result.status is InvariantStatus.NO_PLAN_PROVED else EXIT_INVARIANT_WRONG


def cli_check(domain, queries, args) -> Objective:
    """Refuse a bad ``--minimize`` before any query runs: a term that is no integer fluent, or
    ``--over-lengths`` on an open range without ``--max-horizon``."""
    objective = Objective.parse(args.minimize, domain.program.signature)
    for q in queries:
        if args.over_lengths and q.hi is None and args.max_horizon is None and q.invariant is None:
            raise CPlusError(f"--over-lengths searches every length of the query's maxstep range, and query "
                             f"'{q.label}' has {q.lo}..infinity: give --max-horizon N")
    return objective


def cli_solve(domain, query, args, wanted: int, on_horizon):
    """``cplus plan --minimize``'s run of one query: the result (whose text and JSON,
    ``Domain.format`` and ``Domain.to_json``, hold the optimum), and a function that says on
    standard error what is known of an optimum not proved and returns the exit code it calls
    for (0; 12 a plan not proved optimal; 130 interrupted)."""
    objective = Objective.parse(args.minimize, domain.program.signature)
    result = run_optimal(domain.theory_for(query), query, objective, wanted, args.solver or "glucose4",
                         args.max_horizon, args.over_lengths, args.time_limit, on_horizon=on_horizon)

    def report(doc: dict | None) -> int:
        opt = result.optimum
        if opt is None or opt.proved:
            return EXIT_OK
        if doc is None:
            print(f"% {optimum_text(result).strip()}", file=sys.stderr)
        return EXIT_INTERRUPTED if opt.stopped == "interrupted" else EXIT_NOT_PROVED
    return result, report


def robot_check(domain, args) -> Objective:
    """``--minimize`` for a robot task: the term, refused before anything is planned as for
    a plain domain; ``--over-lengths`` is for plain domains (refused in one line)."""
    if args.over_lengths:
        raise CPlusError("--over-lengths applies to plain domains; a robot task's cheapest collision-free plan is "
                         "searched at the shortest length that has one")
    return Objective.parse(args.minimize, domain.program.signature)


def robot_report(opt: Optimum, json_output: bool) -> int:
    """Print a robot task's optimum line (unless JSON, where it is in the result) and return
    the exit code it calls for."""
    if not json_output:
        sys.stdout.write(line(opt, None))
    if opt.proved:
        return EXIT_OK
    return EXIT_INTERRUPTED if opt.stopped == "interrupted" else EXIT_NOT_PROVED


