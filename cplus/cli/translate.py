"""``cplus translate DOMAIN.pddl PROBLEM.pddl -o OUT.cp``: the C+ theory a PDDL problem
becomes (:mod:`cplus.pddl.translate`), the one ``cplus plan`` solves."""
from __future__ import annotations

import argparse
import sys

from cplus.cli.common import EXIT_OK, OneLineArgumentParser, checked, nonempty
from cplus.cli.paths import Input, Output, check_paths
from cplus.options import check_max_horizon

__all__ = ["build_parser", "main"]


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog="cplus translate",
                              description="Write the C+ theory of a PDDL domain and problem.")
    p.add_argument("domain", help="the PDDL domain file")
    p.add_argument("problem", help="the PDDL problem file")
    p.add_argument("-o", "--output", type=nonempty, default="-", metavar="OUT.cp",
                   help="where to write the C+ theory ('-', the default: standard output)")
    p.add_argument("--sequential", action="store_true", help="one action a step (default: forall-step concurrency)")
    p.add_argument("--max-horizon", type=checked(check_max_horizon, int), default=None, metavar="N",
                   help="the query's last maxstep (default: infinity)")
    return p


def main(args: argparse.Namespace) -> int:
    check_paths("cplus translate", [Input(args.domain, "the domain"), Input(args.problem, "the problem")],
                [Output("--output", args.output, stdout=True)])
    from cplus.pddl import read_problem, translate
    problem = read_problem(args.domain, args.problem)
    text = translate(problem, args.sequential, None, args.max_horizon).text
    if args.output == "-":
        sys.stdout.write(text)
    else:
        from cplus.files import write_output
        write_output(args.output, text)
    return EXIT_OK
