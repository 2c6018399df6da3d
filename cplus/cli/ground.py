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
    p.add_argument("file", help="the C+ file ('-' reads standard input)")
    p.add_argument("--maxstep", type=nonneg, required=True, metavar="N", help="the horizon to write")
    p.add_argument("--dimacs", required=True, metavar="OUT", help="output file ('-' for stdout)")
    p.add_argument("--query", "-q", metavar="LABEL", help="add this query's conditions")
    p.add_argument("--extern", action="append", default=[], metavar="FILE.py",
                   help="a Python file whose functions are external predicates/functions")
    p.add_argument("--scene", metavar="FILE",
                   help="a robot task's scene (default: scene.toml beside the domain, if there is one)")
    return p


def main(args: argparse.Namespace) -> int:
    from cplus.api import Domain
    from cplus.robot.offline.task import RobotTask, scene_beside
    from cplus.sat.dimacs import horizon_cnf, write_dimacs
    if args.dimacs != "-":   # before grounding, which may take a while
        problem = _unwritable(args.dimacs)
        if problem:
            print(f"cplus ground: cannot write '{args.dimacs}': {problem}", file=sys.stderr)
            return EXIT_INPUT
    warn = Warnings()
    from cplus.load import STDIN
    scene = args.scene or (None if args.file == STDIN else scene_beside(args.file))
    domain: Domain = (RobotTask.load(args.file, scene, args.extern).domain if scene  # type: ignore[assignment]
                      else Domain.load(args.file, externals(args.extern)))
    q = query(domain, args.query, "cplus ground") if args.query else None
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


def _unwritable(path: str) -> str | None:
    """Why ``path`` cannot be written, or None (checked without creating or truncating it)."""
    import os
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        return "it is a directory"
    if not os.path.isdir(folder):
        return f"no such directory '{folder}'"
    if os.path.exists(path):
        return None if os.access(path, os.W_OK) else "permission denied"
    return None if os.access(folder, os.W_OK | os.X_OK) else f"permission denied in '{folder}'"
