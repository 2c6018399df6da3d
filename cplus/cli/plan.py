"""``cplus plan FILE``: answer the queries of a C+ file, as CCALC prints them or as JSON.

A file with a ``scene.toml`` beside it (or ``--scene``) is a robot task: its plans are refined
until collision-free (:func:`cplus.robot.offline.refine`) and may be exported as trajectories.
"""
from __future__ import annotations

import argparse
import sys
import time

from cplus.cli.animation_options import FrameProgress, add_animation_options, animation_check
from cplus.cli.common import (
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    EXIT_LIMIT,
    EXIT_NO_PLAN,
    EXIT_OK,
    OneLineArgumentParser,
    Warnings,
    checked,
    clear_progress,
    externals,
    file_loc,
    horizon_progress,
    nonempty,
    positive,
    positive_int,
    query,
    query_label,
    robot_exit_code,
    scene_beside,
)
from cplus.cli.paths import Input, Output, check_paths
from cplus.options import (
    WORKERS_PER_CORE,
    check_gamma,
    check_jobs,
    check_max_horizon,
    check_max_iterations,
    check_solutions,
    check_solver,
    check_term,
    check_time_limit,
)

__all__ = ["build_parser", "main", "add_common", "add_robot_options", "inputs_of"]


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog="cplus plan", description="Answer the queries of a C+ file.")
    p.add_argument("file", help="the C+ file ('-' reads standard input), or a PDDL domain (DOMAIN.pddl)")
    p.add_argument("problem", nargs="?", help="with a PDDL domain: the PDDL problem (docs/pddl.md)")
    p.add_argument("--sequential", action="store_true",
                   help="PDDL input: one action a step (default: forall-step, several non-interfering actions)")
    which = p.add_mutually_exclusive_group()
    which.add_argument("--query", "-q", type=query_label, metavar="LABEL", help="run only this query ('states': every state)")
    which.add_argument("--nmquery", type=query_label, metavar="LABEL",
                       help="run only this nmquery (its rules completed on their own, as CCALC's nmquery)")
    p.add_argument("-n", type=checked(check_solutions, int), default=None, metavar="N",
                   help="number of solutions (0 = all; default 1, all for '--query states')")
    p.add_argument("--json", action="store_true", help="print the result as cplus.plan/1 JSON")
    p.add_argument("--stats", action="store_true", help="print sizes and times per horizon on stderr")
    g = p.add_argument_group("cost-optimal plans")
    g.add_argument("--minimize", type=checked(check_term), metavar="TERM",
                   help="the cheapest plan by TERM, an integer fluent or a sum of them at the last step "
                        "(shortest plan first, then cheapest at that length, proved); PDDL input: total-cost")
    g.add_argument("--over-lengths", action="store_true",
                   help="with --minimize: the cheapest over the query's whole maxstep range")
    g.add_argument("--time-limit", type=checked(check_time_limit, float), default=None, metavar="SECONDS",
                   help="with --minimize: stop looking for cheaper plans after SECONDS (exit 12, the best so far; "
                        "the first plan is always waited for)")
    add_common(p)
    g = p.add_argument_group("several horizons at once, on worker processes")
    g.add_argument("--jobs", "-j", type=checked(check_jobs, int), default=None, metavar="N|auto",
                   help=f"solve on up to N worker processes ('auto': the cores there are, only once horizons get "
                        f"hard); no more start than horizons can run at once, nor {WORKERS_PER_CORE} per core")
    g.add_argument("--strategy", choices=("sequential", "A", "B"), default=None,
                   help="which horizons run at once: one (sequential), N (A, the default), or horizon k+i at "
                        "a share gamma^i of the shortest unfinished k's time (B)")
    g.add_argument("--gamma", type=checked(check_gamma, float), default=None, metavar="G", help="strategy B's rate, 0 < G <= 1 (default 0.8)")
    g.add_argument("--any-length", action="store_true",
                   help="the first plan found, not proved shortest (say which shorter maxsteps are open)")
    add_robot_options(p)
    return p


def add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--solver", type=checked(check_solver), default=None, metavar="NAME",
                   help="pysat solver (default glucose4; minisat22 for a robot task's refinement)")
    p.add_argument("--max-horizon", type=checked(check_max_horizon, int), default=None, metavar="N",
                   help="stop an open range N..infinity at this maxstep")
    p.add_argument("--extern", type=nonempty, action="append", default=[], metavar="FILE.py",
                   help="a Python file whose functions are external predicates/functions")


def add_robot_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("robot tasks (a scene.toml beside the domain, or --scene)")
    g.add_argument("--scene", type=nonempty, metavar="FILE", help="scene file (default: scene.toml beside the domain)")
    g.add_argument("--no-refine", action="store_true",
                   help="check the first plan and show it, do not refine it (exit 9 if it is not collision-free)")
    g.add_argument("--max-iterations", type=checked(check_max_iterations, int), default=0, metavar="N",
                   help="give up (exit 5) after N refinement iterations (default 0: no limit)")
    g.add_argument("--nogoods", choices=("positions", "actions"), default="positions",
                   help="what a violation teaches: the positions it depends on, at every step (default), or "
                        "the paper's form, the actions executed where the bodies are")
    g.add_argument("--eager", choices=("auto", "yes", "no"), default="auto",
                   help="before the first solve, hand the solver the points an arm cannot hold and the payload "
                        "turns (auto), also every failing move between two grid points (yes), or nothing (no)")
    g.add_argument("--trajectory", metavar="OUT.json", help="write the joint trajectory (cplus.trajectory/1)")
    g.add_argument("--csv", metavar="OUT.csv", help="write the joint trajectory as CSV")
    g.add_argument("--plot", metavar="OUT.png", help="plot the plan (PNG or SVG)")
    add_animation_options(g, "planned")
    g.add_argument("--points-per-step", type=positive_int, default=10, metavar="K",
                   help="trajectory samples per plan step (default 10)")
    g.add_argument("--step-time", type=positive, default=1.0, metavar="SECONDS",
                   help="duration of one plan step (default 1.0; the tick, SECONDS*1000/K, must be whole ms)")


ROBOT_OPTIONS = ("no_refine", "max_iterations", "nogoods", "eager", "trajectory", "csv", "plot",
                 "points_per_step", "step_time", "animate", "frames", "dpi")
"""The options that only a robot task uses (a plain domain warns when one is given)."""


def main(args: argparse.Namespace) -> int:
    from cplus.load import STDIN
    if args.problem is not None or args.file.lower().endswith(".pddl"):
        from cplus.cli.plan_pddl import plan_pddl
        return plan_pddl(args)
    if args.sequential:
        print("cplus plan: error: --sequential applies to PDDL input (a C+ file says noconcurrency)", file=sys.stderr)
        return EXIT_INPUT
    if args.jobs is not None:
        if args.minimize:
            print("cplus plan: error: --minimize runs in one process: leave out --jobs", file=sys.stderr)
            return EXIT_INPUT
        from cplus.cli.plan_jobs import check_options
        error = check_options(args)
        if error:
            print(error, file=sys.stderr)
            return EXIT_INPUT
    else:
        for flag, given in (("--strategy", args.strategy), ("--gamma", args.gamma), ("--any-length", args.any_length)):
            if given:
                print(f"cplus plan: error: {flag} applies with --jobs N", file=sys.stderr)
                return EXIT_INPUT
    scene_path = args.scene or (None if args.file == STDIN else scene_beside(args.file))
    if scene_path is not None:
        args.n = 1 if args.n is None else args.n
        return _plan_robot_task(args, scene_path)
    if (args.over_lengths or args.time_limit is not None) and not args.minimize:
        flag = "--over-lengths" if args.over_lengths else "--time-limit"
        print(f"cplus plan: error: {flag} applies to --minimize", file=sys.stderr)
        return EXIT_INPUT
    defaults = build_parser()
    for dest in ROBOT_OPTIONS:
        if getattr(args, dest) != defaults.get_default(dest):
            flag = "--" + dest.replace("_", "-")
            print(f"cplus plan: warning: {flag} applies to robot tasks only (no scene.toml beside {args.file}, "
                  "no --scene); ignored", file=sys.stderr)
    return _plan_domain(args)


def _plan_domain(args: argparse.Namespace) -> int:
    from cplus.api import Domain
    from cplus.planner import PlanStatus
    from cplus.sat.solver import DEFAULT_SOLVER

    warn = Warnings()
    t0 = time.perf_counter()
    domain = Domain.load(args.file, externals(args.extern))
    warn(domain.diagnostics)
    if args.query or args.nmquery:
        wanted_labels = [(args.nmquery, True) if args.nmquery else (args.query, False)]
    else:
        wanted_labels = [(lab, False) for lab in domain.labels] + [(lab, True) for lab in domain.nm_labels]
    if not wanted_labels:
        from cplus.errors import QueryError
        raise QueryError("this file has no queries; use '--query states' to list its states",
                         file_loc(args.file))
    queries = [query(domain, lab, "cplus plan", nm, refused=True) for lab, nm in wanted_labels]
    if args.minimize:
        from cplus.cli.optimal import cli_check
        cli_check(domain, [q for q in queries if q.error is None], args)
    loaded = f"% {args.file}: loaded in {time.perf_counter() - t0:.3f} s; "
    code = EXIT_OK
    docs = []
    for q in queries:
        if len(queries) > 1 and not args.json:
            print(f"% {'nmquery' if q.nm else 'query'} {q.label}")
        if q.error is not None:           # refused alone, as CCALC does; the others are answered
            from cplus.cli import prefixed
            sys.stdout.flush()
            print(prefixed(q.error.render(), "plan"), file=sys.stderr)
            code = max(code, EXIT_INPUT)
            continue
        t1 = time.perf_counter()
        theory = domain.theory_for(q)     # only what the query's initial state can reach
        warn(domain.diagnostics)
        if args.stats:
            pruned = f", {len(theory.dead)} fluent values unreachable" if theory.initial is not None else ""
            print(f"{loaded or '% '}grounded {theory.rule_count} rules over {len(theory.atoms)} atoms{pruned} in "
                  f"{time.perf_counter() - t1:.3f} s", file=sys.stderr)
            loaded = ""
        if q.invariant is not None:       # maxstep :: any: a proof, not a search
            from cplus.cli.optimal import proof_exit_code
            proof = domain.prove(q.label, args.solver)
            if args.json:
                docs.append(domain.proof_json(proof))
            else:
                sys.stdout.write(domain.format_proof(proof))
            code = max(code, proof_exit_code(proof))
            continue
        every_state = q.label == "states" and q.loc is None   # the built-in query, not a file's
        wanted = args.n if args.n is not None else 0 if every_state else 1
        if args.minimize:
            from cplus.cli.optimal import cli_solve
            result, extra = cli_solve(domain, q, args, wanted, horizon_progress(args.stats))
        elif args.jobs is not None and not q.nm:      # an nmquery's own completion is solved in this process
            from cplus.cli.plan_jobs import solve
            result = solve(domain, q.label, wanted, args)
        else:
            result = domain.solve(q.label, wanted, args.solver or DEFAULT_SOLVER, args.max_horizon,
                                  horizon_progress(args.stats), nmquery=q.nm)
        clear_progress(args.stats)
        warn(domain.diagnostics)
        if args.stats and result.stats:
            print(f"% templates built in {result.template_s:.3f} s; total "
                  f"{sum(s.encode_s for s in result.stats):.3f} s encoding, "
                  f"{sum(s.solve_s for s in result.stats):.3f} s solving", file=sys.stderr)
        if args.json:
            docs.append(domain.to_json(result))
            if args.jobs is not None and not q.nm:
                docs[-1]["parallel"] = result.parallel
        else:
            sys.stdout.write(domain.format(result))
        if args.minimize:
            code = max(code, extra(docs[-1] if args.json else None))
            if code == EXIT_INTERRUPTED:
                break
        if result.status is PlanStatus.NO_PLAN:
            code = max(code, EXIT_NO_PLAN)
        elif result.status is PlanStatus.HORIZON_LIMIT:
            if not args.json:
                print(f"% no solution up to maxstep {args.max_horizon} (--max-horizon)", file=sys.stderr)
            code = max(code, EXIT_LIMIT)
    if args.json:
        import json

        from cplus.output import PLAN_FORMAT
        json.dump({"format": PLAN_FORMAT, "file": args.file, "results": [
            {k: v for k, v in d.items() if k not in ("format", "file")} for d in docs]}, sys.stdout, indent=1)
        sys.stdout.write("\n")
    return code


def _plan_robot_task(args: argparse.Namespace, scene_path: str) -> int:
    """Check the options, load, plan and refine each query, print, export."""
    from cplus.output import PLAN_FORMAT, Display, format_result
    from cplus.robot import RefineStatus, RobotTask, TaskError, check_outputs, export_plan, refine
    if args.n != 1:
        print("cplus plan: error: -n applies to plain domains; a robot task yields one refined plan", file=sys.stderr)
        return EXIT_INPUT
    if args.nmquery:
        print("cplus plan: error: --nmquery applies to plain domains; a robot task refines the plans of its queries",
              file=sys.stderr)
        return EXIT_INPUT
    check_outputs(plot=args.plot, trajectory_json=args.trajectory, csv=args.csv,
                  points_per_step=args.points_per_step, step_time=args.step_time)
    problem = animation_check(args.animate, "--animate", "cplus plan")
    if problem is not None:
        print(problem, file=sys.stderr)
        return EXIT_INPUT
    check_paths("cplus plan", inputs_of(args, scene_path),
                [Output(option, path) for option, path in (("--trajectory", args.trajectory), ("--csv", args.csv),
                                                           ("--plot", args.plot), ("--animate", args.animate))])
    warn = Warnings()
    t0 = time.perf_counter()
    task = RobotTask.load(args.file, scene_path, args.extern)
    domain = task.domain
    warn(domain.diagnostics)  # type: ignore[attr-defined]
    labels = [args.query] if args.query else domain.labels  # type: ignore[attr-defined]
    for label in labels:
        query(domain, label, "cplus plan")
    objective = None
    if args.minimize:
        from cplus.cli.optimal import robot_check
        objective = robot_check(domain, args)
    exports = [f for f, v in (("--plot", args.plot), ("--trajectory", args.trajectory), ("--csv", args.csv),
                              ("--animate", args.animate)) if v]
    if exports and len(labels) > 1:
        raise TaskError(f"{exports[0]} writes one plan, and {args.file} has queries {', '.join(labels)}: "
                        "choose one with --query")
    if args.stats:
        print(f"% {args.file}: loaded with the scene {scene_path} in {time.perf_counter() - t0:.3f} s; "
              "grounding ...", file=sys.stderr, flush=True)
    elif sys.stderr.isatty():
        print("\r% grounding ...", end="", file=sys.stderr, flush=True)
    t1 = time.perf_counter()
    theory = domain.theory  # type: ignore[attr-defined]
    clear_progress(args.stats)
    if args.stats:
        print(f"% grounded {theory.rule_count} rules over {len(theory.atoms)} atoms in "
              f"{time.perf_counter() - t1:.3f} s", file=sys.stderr)
    warn(domain.diagnostics)  # type: ignore[attr-defined]
    code = EXIT_OK
    results = []
    display = Display(domain.program)  # type: ignore[attr-defined]
    proofs = {}
    for label in labels:
        if len(labels) > 1 and not args.json:
            print(f"% query {label}")
        if domain.query(label).invariant is not None:  # type: ignore[attr-defined]
            from cplus.cli.optimal import proof_exit_code  # maxstep :: any, over the domain's fluents
            proof = proofs[label] = domain.prove(label, args.solver)  # type: ignore[attr-defined]
            if not args.json:
                sys.stdout.write(domain.format_proof(proof))  # type: ignore[attr-defined]
            code = max(code, proof_exit_code(proof))
            continue
        on_horizon = horizon_progress(args.stats)

        def on_iteration(it) -> None:
            clear_progress(args.stats)
            print(it.text(), file=sys.stderr)
        options = dict(nogoods=args.nogoods, eager={"auto": None, "yes": True, "no": False}[args.eager],
                       on_iteration=on_iteration, on_horizon=on_horizon,
                       on_precheck=lambda pre: print(pre.text(), file=sys.stderr) if args.stats else None)
        if args.jobs is not None and not args.no_refine:
            from cplus.cli.plan_jobs import refine_on_jobs
            result = refine_on_jobs(task, label, args, options)
        else:
            result = refine(task, label, args.max_iterations, args.max_horizon, args.solver, not args.no_refine,
                            minimize=objective, time_limit=args.time_limit, **options)
        clear_progress(args.stats)
        warn(domain.diagnostics)  # type: ignore[attr-defined]
        results.append((label, result))
        if not args.json:
            shown = result.shown
            sys.stdout.write(format_result(display, result.no_solution_with_maxstep, [shown] if shown else [],
                                           False))
        if result.optimum is not None:
            from cplus.cli.optimal import robot_report
            code = max(code, robot_report(result.optimum, args.json))
        if args.stats:
            print(_summary(result), file=sys.stderr)
        if result.reason:
            print(f"% {result.reason}", file=sys.stderr)
        code = max(code, robot_exit_code(result.status))
    if args.json:
        import json
        done = dict(results)
        json.dump({"format": PLAN_FORMAT, "file": args.file, "results": [
            done[label].to_json(label) if label in done else
            {k: v for k, v in domain.proof_json(proofs[label]).items()  # type: ignore[attr-defined]
             if k not in ("format", "file")} for label in labels]}, sys.stdout, indent=1)
        sys.stdout.write("\n")
        sys.stdout.flush()
    for _, result in results:
        if result.status not in (RefineStatus.FOUND, RefineStatus.UNSAFE) or not exports:
            continue
        unsafe = result.history is None
        try:
            export_plan(task, result.states or result.first_states or [],
                        result.first_violation if unsafe else None, domain_path=args.file,
                        plot=args.plot, trajectory_json=args.trajectory, csv=args.csv,
                        points_per_step=args.points_per_step, step_time=args.step_time,
                        on_write=lambda path: print(f"% wrote {path}", file=sys.stderr))
        except TaskError as exc:
            if not unsafe:
                raise
            print(f"cplus plan: warning: {exc.message}; not written: "
                  f"{', '.join(p for p in (args.trajectory, args.csv) if p)}", file=sys.stderr)
        if args.animate:
            code = max(code, _animate(task, result.states or result.first_states or [],
                                      result.first_violation if unsafe else None, args))
    return code


def inputs_of(args: argparse.Namespace, scene_path: str | None) -> list[Input]:
    """What ``cplus plan`` (and ``run``, ``ground``) reads: no output may be one of them."""
    return [Input(args.file, "the domain"), Input(scene_path, "the scene"),
            *(Input(f, "an --extern file") for f in args.extern)]


def _animate(task, states: list, violation, args: argparse.Namespace) -> int:
    """``--animate FILE``: the plan's trajectory moving over the scene (an unsafe plan too,
    with its first violation in the title: seeing it move shows where it fails)."""
    import os

    import trajectory
    from cplus.files import output_path
    try:
        traj = trajectory.build_trajectory(task.scene, states, points_per_step=args.points_per_step,
                                           step_time_s=args.step_time, check=False)
        title = trajectory.plan_title(task.scene, len(states) - 1, os.path.basename(args.file))
        if violation is not None:
            title += f", not collision-free ({violation.kind.value} from step {violation.step})"
        with output_path(args.animate) as tmp:
            trajectory.animate_run(task.scene, traj, tmp, title=title, max_frames=args.frames, dpi=args.dpi,
                                   on_progress=FrameProgress("cplus plan", args.animate, sys.stderr))
    except trajectory.TrajectoryError as exc:
        print(f"cplus plan: error: cannot animate the plan: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except OSError as exc:
        print(f"cplus plan: error: --animate {args.animate}: cannot write: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_INPUT
    print(f"% wrote {args.animate}", file=sys.stderr)
    return EXIT_OK


def _summary(result) -> str:
    """The --stats line of a refinement: iterations, nogoods, sizes at the last horizon."""
    st = result.stats[-1] if result.stats else None
    pre = result.precheck
    size = f"; maxstep {st.maxstep}: {st.variables} variables, {st.clauses} clauses" if st else ""
    eager = (f" (+ {pre.points} points, {pre.motions} moves, {pre.length_pairs} payload turns up front)"
             if pre else "")
    seconds = sum(it.seconds for it in result.iterations)
    return (f"% refinement: {len(result.iterations)} iterations, {result.learned} nogoods learned{eager}{size}; "
            f"checking and learning {seconds:.3f} s, solving {sum(s.solve_s for s in result.stats):.3f} s")
