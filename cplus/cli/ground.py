"""``cplus ground FILE --maxstep N --dimacs OUT``: the CNF of one horizon in DIMACS form.

A robot task (a ``scene.toml`` beside the domain, or ``--scene``) is grounded with the
scene's externals (``collision/4``), after its bindings are checked against the domain.
"""
from __future__ import annotations

import argparse
import sys

from cplus.cli.common import (
    EXIT_INPUT,
    EXIT_OK,
    OneLineArgumentParser,
    Warnings,
    checked,
    externals,
    nonempty,
    query,
    query_label,
)
from cplus.cli.paths import Output, check_paths
from cplus.options import check_max_horizon

__all__ = ["build_parser", "main"]


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog="cplus ground", description="Write the CNF of one horizon in DIMACS form.")
    p.add_argument("file", help="the C+ file ('-' reads standard input)")
    p.add_argument("--maxstep", type=checked(check_max_horizon, int), required=True, metavar="N", help="the horizon to write")
    p.add_argument("--dimacs", type=nonempty, required=True, metavar="OUT", help="output file ('-' for stdout)")
    p.add_argument("--query", "-q", type=query_label, metavar="LABEL", help="add this query's conditions")
    p.add_argument("--extern", type=nonempty, action="append", default=[], metavar="FILE.py",
                   help="a Python file whose functions are external predicates/functions")
    p.add_argument("--scene", type=nonempty, metavar="FILE",
                   help="a robot task's scene (default: scene.toml beside the domain, if there is one)")
    return p


def main(args: argparse.Namespace) -> int:
    from cplus.api import Domain
    from cplus.cli.plan import inputs_of
    from cplus.files import open_output
    from cplus.load import STDIN
    from cplus.robot.offline.task import RobotTask, scene_beside
    from cplus.sat.dimacs import horizon_cnf, write_dimacs
    scene = args.scene or (None if args.file == STDIN else scene_beside(args.file))
    # before grounding, which may take a while
    check_paths("cplus ground", inputs_of(args, scene), [Output("--dimacs", args.dimacs, stdout=True)])
    warn = Warnings()
    domain: Domain = (RobotTask.load(args.file, scene, args.extern).domain if scene  # type: ignore[assignment]
                      else Domain.load(args.file, externals(args.extern)))
    q = query(domain, args.query, "cplus ground") if args.query else None
    nvars, clauses, names = horizon_cnf(domain.theory, args.maxstep, q)
    warn(domain.diagnostics)
    if args.dimacs == "-":
        write_dimacs(sys.stdout, nvars, clauses, names)
    else:
        try:
            with open_output(args.dimacs) as fh:
                write_dimacs(fh, nvars, clauses, names)  # type: ignore[arg-type]
        except OSError as exc:
            print(f"cplus ground: error: --dimacs {args.dimacs}: cannot write: {exc.strerror}", file=sys.stderr)
            return EXIT_INPUT
        print(f"% wrote {args.dimacs}: {nvars} variables, {len(clauses)} clauses (maxstep {args.maxstep})",
              file=sys.stderr)
    return EXIT_OK
