"""The ``cplus`` command line.

Exit codes: 0 every query has a solution; 1 some query has no solution in its maxstep
range (CCALC's "No solution with maxstep N." lines are printed); 2 bad input or usage;
3 an open maxstep range (``N..infinity``) reached ``--max-horizon`` without a solution;
4 the payload pipeline found no collision-free plan; 130 interrupted.
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import sys
import time

__all__ = ["main"]

EXIT_OK, EXIT_NO_PLAN, EXIT_INPUT, EXIT_LIMIT, EXIT_NO_SAFE_PLAN, EXIT_INTERRUPTED = 0, 1, 2, 3, 4, 130


def _nonneg(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got '{text}'") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got '{text}'")
    return v


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="cplus", description="C+ planning in the style of CCALC, with "
                                "trajectories for LEGO NXT arms.")
    sub = p.add_subparsers(dest="command", metavar="{plan,ground,run,brick,execute}")

    pl = sub.add_parser("plan", help="answer the queries of a C+ file")
    pl.add_argument("file")
    pl.add_argument("--query", "-q", metavar="LABEL", help="run only this query ('states': all states)")
    pl.add_argument("-n", type=_nonneg, default=1, metavar="N", help="number of solutions (0 = all)")
    pl.add_argument("--json", action="store_true", help="print the result as cplus.plan/1 JSON")
    pl.add_argument("--stats", action="store_true", help="print sizes and times per horizon on stderr")
    _common(pl)
    _payload_options(pl)
    pl.set_defaults(func=_cmd_plan)

    gr = sub.add_parser("ground", help="write the CNF of one horizon in DIMACS form")
    gr.add_argument("file")
    gr.add_argument("--maxstep", type=_nonneg, required=True, metavar="N")
    gr.add_argument("--dimacs", required=True, metavar="OUT", help="output file ('-' for stdout)")
    gr.add_argument("--query", "-q", metavar="LABEL", help="add this query's conditions")
    gr.add_argument("--extern", action="append", default=[], metavar="FILE.py",
                    help="a Python file whose functions are external predicates/functions")
    gr.set_defaults(func=_cmd_ground)

    rn = sub.add_parser("run", help="the whole robot job: plan, refine, trajectory, execute, plot")
    rn.add_argument("file", help="a robot task: a C+ domain with a scene.toml beside it (or --scene)")
    rn.add_argument("--query", "-q", metavar="LABEL", default="0", help="the query to plan (default 0)")
    rn.add_argument("--scene", metavar="FILE", help="scene file (default: scene.toml beside the domain)")
    rn.add_argument("--brick", action="append", default=[], metavar="NAME=PORT",
                    help="a robot's brick port, e.g. r1=/dev/rfcomm0 (default: emulated bricks)")
    rn.add_argument("--out", default="out", metavar="DIR",
                    help="where to write the plan, trajectory, execution log and pictures (default out/)")
    rn.add_argument("--max-iterations", type=_nonneg, default=100, metavar="N")
    rn.add_argument("--points-per-step", type=_nonneg, default=10, metavar="K")
    rn.add_argument("--step-time", type=float, default=1.0, metavar="SECONDS")
    _common(rn)
    rn.set_defaults(func=_cmd_run)
    return p


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--solver", default=None, metavar="NAME", help="pysat solver (default glucose4)")
    p.add_argument("--max-horizon", type=_nonneg, default=None, metavar="N",
                   help="stop an open range N..infinity at this maxstep")
    p.add_argument("--extern", action="append", default=[], metavar="FILE.py",
                   help="a Python file whose functions are external predicates/functions")


def _payload_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("robot tasks (a scene.toml beside the domain, or --scene)")
    g.add_argument("--scene", metavar="FILE", help="scene file (default: scene.toml beside the domain)")
    g.add_argument("--no-refine", action="store_true", help="show the first plan, do not refine it")
    g.add_argument("--max-iterations", type=_nonneg, default=100, metavar="N",
                   help="refinement iterations before giving up (default 100)")
    g.add_argument("--trajectory", metavar="OUT.json", help="write the joint trajectory (cplus.trajectory/1)")
    g.add_argument("--csv", metavar="OUT.csv", help="write the joint trajectory as CSV")
    g.add_argument("--plot", metavar="OUT.png", help="plot the plan (PNG or SVG)")
    g.add_argument("--points-per-step", type=_nonneg, default=10, metavar="K")
    g.add_argument("--step-time", type=float, default=1.0, metavar="SECONDS")


# --------------------------------------------------------------------------- plan


def _externals(files: list[str]):
    from cplus.externals import load_extern_file
    from cplus.resolve import BUILTIN_EXTERNALS
    ext = BUILTIN_EXTERNALS.copy()
    for f in files:
        load_extern_file(f, ext)
    return ext


def _warn(diag, seen: set) -> None:
    for d in diag.items:
        key = id(d)
        if key not in seen:
            seen.add(key)
            print(d.render(), file=sys.stderr)


def _progress(enabled: bool):
    tty = sys.stderr.isatty()

    def on_horizon(st) -> None:
        if enabled:
            verdict = "solution" if st.satisfiable else "no solution"
            print(f"% maxstep {st.maxstep}: {st.variables} variables, {st.clauses} clauses, "
                  f"encode {st.encode_s:.3f} s, solve {st.solve_s:.3f} s: {verdict}", file=sys.stderr)
        elif tty:
            print(f"\r% maxstep {st.maxstep} ...", end="", file=sys.stderr, flush=True)
    return on_horizon


def _clear_progress(enabled: bool) -> None:
    if not enabled and sys.stderr.isatty():
        print("\r\033[K", end="", file=sys.stderr, flush=True)


def _cmd_plan(args: argparse.Namespace) -> int:
    from cplus.api import Domain
    from cplus.planner import PlanStatus
    from cplus.sat.solver import DEFAULT_SOLVER

    scene_path = _scene_path(args)
    if scene_path is not None:
        from cplus.pipeline import plan_command
        return plan_command(args, scene_path)
    seen: set = set()
    t0 = time.perf_counter()
    domain = Domain.load(args.file, _externals(args.extern))
    _warn(domain.diagnostics, seen)
    labels = [args.query] if args.query else domain.labels
    if not labels:
        from cplus.errors import QueryError
        raise QueryError("this file has no queries; use '--query states' to list its states",
                         _file_loc(args.file))
    queries = [_query(domain, lab, args.file) for lab in labels]
    t1 = time.perf_counter()
    theory = domain.theory
    t2 = time.perf_counter()
    _warn(domain.diagnostics, seen)
    if args.stats:
        print(f"% {args.file}: loaded in {t1 - t0:.3f} s; grounded {theory.rule_count} rules over "
              f"{len(theory.atoms)} atoms in {t2 - t1:.3f} s", file=sys.stderr)
    code = EXIT_OK
    docs = []
    for q in queries:
        if len(queries) > 1 and not args.json:
            print(f"% query {q.label}")
        result = domain.solve(q.label, args.n, args.solver or DEFAULT_SOLVER, args.max_horizon,
                              _progress(args.stats))
        _clear_progress(args.stats)
        _warn(domain.diagnostics, seen)
        if args.stats and result.stats:
            print(f"% templates built in {result.template_s:.3f} s; total "
                  f"{sum(s.encode_s for s in result.stats):.3f} s encoding, "
                  f"{sum(s.solve_s for s in result.stats):.3f} s solving", file=sys.stderr)
        if args.json:
            docs.append(domain.to_json(result))
        else:
            sys.stdout.write(domain.format(result, numbered=args.n != 1))
        if result.status is PlanStatus.NO_PLAN:
            code = max(code, EXIT_NO_PLAN)
        elif result.status is PlanStatus.HORIZON_LIMIT:
            if not args.json:
                print(f"% no solution up to maxstep {args.max_horizon} (--max-horizon)", file=sys.stderr)
            code = max(code, EXIT_LIMIT)
    if args.json:
        from cplus.output import PLAN_FORMAT
        json.dump({"format": PLAN_FORMAT, "file": args.file, "results": [
            {k: v for k, v in d.items() if k not in ("format", "file")} for d in docs]}, sys.stdout, indent=1)
        sys.stdout.write("\n")
    return code


def _query(domain, label: str, path: str):
    from cplus.errors import QueryError
    try:
        return domain.query(label)
    except QueryError as exc:
        exc.loc = _file_loc(path)
        raise


def _file_loc(path: str):
    from cplus.errors import Location, Source
    from cplus.load import read_text
    return Location(Source(path, read_text(path)), 0, 0)


def _scene_path(args: argparse.Namespace) -> str | None:
    if getattr(args, "scene", None):
        return args.scene
    beside = os.path.join(os.path.dirname(os.path.abspath(args.file)), "scene.toml")
    return beside if os.path.isfile(beside) else None


# --------------------------------------------------------------------------- ground


def _cmd_ground(args: argparse.Namespace) -> int:
    from cplus.api import Domain
    from cplus.sat.dimacs import horizon_cnf, write_dimacs
    seen: set = set()
    domain = Domain.load(args.file, _externals(args.extern))
    query = _query(domain, args.query, args.file) if args.query else None
    nvars, clauses, names = horizon_cnf(domain.theory, args.maxstep, query)
    _warn(domain.diagnostics, seen)
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


def _cmd_run(args: argparse.Namespace) -> int:
    from cplus.pipeline import run_command
    return run_command(args)


# --------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "brick":
        from nxt_link.cli import brick_main
        return brick_main(argv[1:])
    if argv and argv[0] == "execute":
        from cplus.execute import execute_main
        return execute_main(argv[1:])
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_INPUT
    from cplus.errors import CPlusError
    # A planning command is a short process that allocates millions of small objects and
    # creates almost no reference cycles: the cyclic collector only costs time here.
    gc.disable()
    try:
        return args.func(args)
    except CPlusError as exc:
        print(exc.render(), file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print("cplus: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:  # pragma: no cover
            pass
        return EXIT_OK
    finally:
        gc.enable()


def run() -> None:  # pragma: no cover - the console script; tests call main()
    """Entry point of the ``cplus`` script: run, flush, and leave without tearing down the
    grounded theory object by object (a tenth of a second on large domains)."""
    code = main()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except BrokenPipeError:
        pass
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()
