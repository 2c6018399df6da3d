"""``cplus plan DOMAIN.pddl PROBLEM.pddl``: a PDDL problem planned through its C+
translation (:mod:`cplus.pddl`), printed in the IPC plan format or as JSON.

Each plan is checked by unified-planning's validator before it is printed; a plan it refuses
is an internal error (exit 70), never printed.
"""
from __future__ import annotations

import argparse
import sys

from cplus.cli.common import EXIT_INPUT, EXIT_LIMIT, EXIT_NO_PLAN_PROVED, EXIT_OK

__all__ = ["EXIT_INTERNAL", "plan_pddl", "pddl_files", "refused_options"]

EXIT_INTERNAL = 70
"""A plan the validator refused: a bug of cplus's translation, reported, the plan not printed."""

_C_PLUS_ONLY = (("query", "--query"), ("nmquery", "--nmquery"), ("n", "-n"), ("jobs", "--jobs"),
                ("strategy", "--strategy"), ("gamma", "--gamma"), ("any_length", "--any-length"),
                ("extern", "--extern"), ("scene", "--scene"), ("trajectory", "--trajectory"), ("csv", "--csv"),
                ("plot", "--plot"), ("animate", "--animate"))


def pddl_files(args: argparse.Namespace, prog: str) -> tuple[str, str] | str:
    """The domain and problem paths, or the one-line error of a command line that does not
    give both."""
    if args.problem is None:
        return (f"{prog}: error: {args.file} is PDDL: give the domain and the problem "
                f"({prog} DOMAIN.pddl PROBLEM.pddl)")
    return args.file, args.problem


def refused_options(args: argparse.Namespace, prog: str) -> str | None:
    for dest, flag in _C_PLUS_ONLY:
        value = getattr(args, dest, None)
        if value not in (None, False, []):
            return f"{prog}: error: {flag} applies to C+ files, not to PDDL input"
    return None


def plan_pddl(args: argparse.Namespace) -> int:
    files = pddl_files(args, "cplus plan")
    problem = refused_options(args, "cplus plan")
    if isinstance(files, str) or problem:
        print(files if isinstance(files, str) else problem, file=sys.stderr)
        return EXIT_INPUT
    if args.minimize is not None and args.minimize.strip() != "total-cost":
        print(f"cplus plan: error: --minimize {args.minimize}: PDDL input minimizes total-cost only", file=sys.stderr)
        return EXIT_INPUT
    if (args.over_lengths or args.time_limit is not None) and not args.minimize:
        flag = "--over-lengths" if args.over_lengths else "--time-limit"
        print(f"cplus plan: error: {flag} applies to --minimize", file=sys.stderr)
        return EXIT_INPUT
    from cplus.pddl import PlanInvalidError, ipc_text, plan_json, plan_problem, read_problem
    domain_path, problem_path = files
    task = read_problem(domain_path, problem_path)
    try:
        plan = plan_problem(task, sequential=args.sequential, minimize=args.minimize is not None,
                            over_lengths=args.over_lengths, max_horizon=args.max_horizon, solver=args.solver,
                            time_limit=args.time_limit, name=f"<C+ of {problem_path}>")
    except PlanInvalidError as exc:
        print(f"cplus plan: {exc.message}", file=sys.stderr)
        return EXIT_INTERNAL
    if args.json:
        import json
        json.dump(plan_json(plan, domain_path, problem_path), sys.stdout, indent=1)
        sys.stdout.write("\n")
    if plan.status == "found":
        if not args.json:
            sys.stdout.write(ipc_text(plan))
        if args.stats:
            print(f"% {len(plan.steps)} steps, {sum(map(len, plan.steps))} actions"
                  + (f", optimal {plan.optimal}" if plan.optimal else ""), file=sys.stderr)
        return EXIT_OK
    if plan.status == "no_plan":         # proved: every plan length up to the bound searched
        if not args.json:
            print("; no plan exists (every plan length searched)", file=sys.stderr)
        return EXIT_NO_PLAN_PROVED
    if not args.json:
        print(f"% no plan up to maxstep {args.max_horizon} (--max-horizon)", file=sys.stderr)
    return EXIT_LIMIT
