"""``cplus ground FILE --maxstep N --dimacs OUT``: the CNF of one horizon in DIMACS form.

A robot task (a ``scene.toml`` beside the domain, or ``--scene``) is grounded with the
scene's externals (``collision/4``), after its bindings are checked against the domain.
"""
from __future__ import annotations

import argparse
import sys

from cplus.cli.common import EXIT_INPUT, EXIT_OK, OneLineArgumentParser, Warnings, externals, nonneg, query

__all__ = ["build_parser", "main"]


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog="cplus ground", description="Write the CNF of one horizon in DIMACS form.")
    p.add_argument("file")
    p.add_argument("--maxstep", type=nonneg, required=True, metavar="N")
    p.add_argument("--dimacs", required=True, metavar="OUT", help="output file ('-' for stdout)")
    p.add_argument("--query", "-q", metavar="LABEL", help="add this query's conditions")
    p.add_argument("--extern", action="append", default=[], metavar="FILE.py",
                   help="a Python file whose functions are external predicates/functions")
    p.add_argument("--scene", metavar="FILE",
                   help="a robot task's scene (default: scene.toml beside the domain, if there is one)")
    return p


def main(args: argparse.Namespace) -> int:
    from cplus.api import Domain
    from cplus.robot.task import RobotTask, scene_beside
    from cplus.sat.dimacs import horizon_cnf, write_dimacs
    warn = Warnings()
    scene = args.scene or scene_beside(args.file)
    domain: Domain = (RobotTask.load(args.file, scene, args.extern).domain if scene  # type: ignore[assignment]
                      else Domain.load(args.file, externals(args.extern)))
    q = query(domain, args.query, args.file) if args.query else None
    nvars, clauses, names = horizon_cnf(domain.theory, args.maxstep, q)
    warn(domain.diagnostics)
    if args.dimacs == "-":
        write_dimacs(sys.stdout, nvars, clauses, names)
    else:
        try:
            with open(args.dimacs, "w", encoding="utf-8") as fh:
                write_dimacs(fh, nvars, clauses, names)
        except OSError as exc:
            print(f"cplus ground: cannot write '{args.dimacs}': {exc.strerror}", file=sys.stderr)
            return EXIT_INPUT
        print(f"% wrote {args.dimacs}: {nvars} variables, {len(clauses)} clauses (maxstep {args.maxstep})",
              file=sys.stderr)
    return EXIT_OK
