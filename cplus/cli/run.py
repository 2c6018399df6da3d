"""``cplus run DOMAIN``: the whole robot job in one command.

Plan and refine (as ``cplus plan``), write the plan, its picture and its trajectory, execute
the trajectory on the bricks (emulated ones on pseudo-terminals when no ``--brick`` is given:
on simulated time with instant answers, as fast as the emulation goes and whatever the
machine's load, unless ``--time-scale X`` asks for the wall clock, e.g. ``--time-scale 1
--latency`` for real time),
read the encoder logs back, report the tracking error and draw the execution (``execution.png``:
the paths, and the motors, the tracking error and the bricks' phases against time).  Every
product goes to ``--out`` and every file written is named on standard error.  Every option and
path is checked before planning starts.

An animation of the run (``--animate``: ``OUT/run.gif``; ``--animate FILE``) is written only
when asked: rendering it takes longer than the emulated run itself, and the pictures show
what a review needs.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys

from cplus.cli import execute
from cplus.cli.animation_options import add_animation_options, animation_check
from cplus.cli.common import (
    EXIT_INPUT,
    CliError,
    OneLineArgumentParser,
    Warnings,
    distinct_bricks,
    horizon_progress,
    nonempty,
    nonneg,
    parse_bricks,
    query,
    query_label,
    robot_exit_code,
)
from cplus.cli.paths import Output, check_paths
from cplus.cli.plan import add_common, inputs_of
from cplus.files import write_output

__all__ = ["build_parser", "main", "PRODUCTS"]

PRODUCTS = {"plan": "plan.txt", "json": "plan.json", "picture": "plan.png", "trajectory": "trajectory.json",
            "csv": "trajectory.csv", "log": "execution.json", "execution": "execution.png", "report": "report.txt"}
"""What ``cplus run`` writes into ``--out``, by role."""

#: The brick program's tick range (``nxt_link.SetpointStream``).
_TICK_MS = (10, 10000)


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog="cplus run",
                              description="The whole robot job: plan, refine, trajectory, execute, plot.")
    p.add_argument("file", help="a robot task: a C+ domain with a scene.toml beside it (or --scene)")
    p.add_argument("--query", "-q", type=query_label, metavar="LABEL", default="0", help="the query to plan (default 0)")
    p.add_argument("--scene", type=nonempty, metavar="FILE", help="scene file (default: scene.toml beside the domain)")
    p.add_argument("--out", type=nonempty, default="out", metavar="DIR",
                   help="where to write the plan, trajectory, execution log and pictures (default out/: the "
                        "folder is created, its parents are not)")
    p.add_argument("--max-iterations", type=nonneg, default=0, metavar="N",
                   help="give up (exit 5) after N refinement iterations (default 0: no limit)")
    p.add_argument("--points-per-step", type=nonneg, default=10, metavar="K",
                   help="trajectory samples between two plan steps (default 10)")
    p.add_argument("--step-time", type=float, default=1.0, metavar="SECONDS",
                   help="duration of one plan step in the trajectory (default 1.0); step time / "
                        "points per step is the tick, a whole number of milliseconds from 10 to 10000")
    execute.add_execution_options(p, fast=True)
    add_animation_options(p, default_file="OUT/run.gif")
    add_common(p)
    return p


def _validate(args: argparse.Namespace) -> tuple[str, dict[str, str]]:
    """Every option and path, before planning.  Returns the scene path and the ports.

    Raises:
        CliError: one line for the user.
    """
    prog = "cplus run"
    if not os.path.isfile(args.file):
        what = "not a regular file" if os.path.exists(args.file) else "no such file"
        raise CliError(f"{prog}: error: cannot read {args.file}: {what}")
    scene_path = args.scene or os.path.join(os.path.dirname(os.path.abspath(args.file)), "scene.toml")
    if not os.path.isfile(scene_path):
        raise CliError(f"{prog}: error: no scene: '{scene_path}' does not exist (give --scene FILE)")
    if args.points_per_step < 1:
        raise CliError(f"{prog}: error: --points-per-step must be at least 1")
    if not (math.isfinite(args.step_time) and args.step_time > 0):
        raise CliError(f"{prog}: error: --step-time must be a positive number of seconds")
    tick = args.step_time * 1000.0 / args.points_per_step
    if abs(tick - round(tick)) > 1e-6 or not _TICK_MS[0] <= round(tick) <= _TICK_MS[1]:
        raise CliError(f"{prog}: error: --step-time {args.step_time:g} s / --points-per-step "
                       f"{args.points_per_step} = a tick of {tick:g} ms; it must be a whole number "
                       f"of milliseconds from {_TICK_MS[0]} to {_TICK_MS[1]}")
    ports = distinct_bricks(parse_bricks(args.brick, prog), prog)
    if args.time_scale is None and ports:  # emulated bricks run on simulated time; real ones keep time
        args.time_scale = 1.0
    if args.animate is True:
        args.animate = os.path.join(args.out, "run.gif")
    problem = animation_check(args.animate, "--animate", prog)
    if problem is not None:
        raise CliError(problem)
    check_paths(prog, inputs_of(args, scene_path),
                [Output("--out", args.out, folder=True),
                 *(Output("--out", os.path.join(args.out, name), inside=args.out) for name in PRODUCTS.values()),
                 Output("--animate", args.animate,
                        inside=args.out if args.animate == os.path.join(args.out, "run.gif") else None)])
    return scene_path, ports


def main(args: argparse.Namespace) -> int:
    """``cplus run``: SIGINT and SIGTERM are handled for the whole job (planning included), and
    the execution inside shares the handling (:class:`cplus.cli.signals.Shutdown` nests)."""
    from cplus.cli.signals import Shutdown
    with Shutdown("cplus run"):
        return _main(args)


def _main(args: argparse.Namespace) -> int:
    from cplus.output import PLAN_FORMAT, Display, format_result
    from cplus.robot import RefineStatus, RobotTask, export_plan, refine
    try:
        scene_path, ports = _validate(args)
    except CliError as exc:
        print(exc, file=sys.stderr)
        return EXIT_INPUT
    out = args.out
    paths = {k: os.path.join(out, name) for k, name in PRODUCTS.items()}
    warn = Warnings()
    task = RobotTask.load(args.file, scene_path, args.extern)
    warn(task.domain.diagnostics)  # type: ignore[attr-defined]
    query(task.domain, args.query, args.file)
    print(f"% planning {args.file} (query {args.query}) with the scene {scene_path}", file=sys.stderr)
    result = refine(task, args.query, args.max_iterations, args.max_horizon, args.solver,
                    on_iteration=lambda it: print(it.text(), file=sys.stderr), on_horizon=horizon_progress(False))
    if result.status is not RefineStatus.FOUND or result.history is None or result.states is None:
        print(f"% {result.reason}", file=sys.stderr)
        return robot_exit_code(result.status)
    text = format_result(Display(task.domain.program), [], [result.history], False)  # type: ignore[attr-defined]
    sys.stdout.write(text)

    def wrote(path: str) -> None:
        print(f"% wrote {path}", file=sys.stderr)

    if not os.path.isdir(out):
        os.mkdir(out)                   # --out asks for this folder (its parent was checked), not its parents
    try:
        write_output(paths["plan"], text)
        wrote(paths["plan"])
        write_output(paths["json"], json.dumps({"format": PLAN_FORMAT, "file": args.file,
                                                "results": [result.to_json(args.query)]}, indent=1))
        wrote(paths["json"])
    except OSError as exc:
        print(f"cplus run: error: --out {out}: cannot write {exc.filename or 'into it'}: {exc.strerror or exc}",
              file=sys.stderr)
        return EXIT_INPUT
    export_plan(task, result.states, None, domain_path=args.file, plot=paths["picture"],
                trajectory_json=paths["trajectory"], csv=paths["csv"], points_per_step=args.points_per_step,
                step_time=args.step_time, on_write=wrote)
    clock = ("simulated time" if args.time_scale is None else
             "real time" if args.time_scale == 1 else f"{args.time_scale:g}x real time")
    where = ("the bricks " + ", ".join(f"{n}={p}" for n, p in ports.items()) if ports else
             f"emulated bricks ({clock}, {'Bluetooth latency' if args.latency else 'no latency'})")
    print(f"% executing {paths['trajectory']} on {where}", file=sys.stderr)
    for stale in [paths[k] for k in ("log", "execution", "report")] + ([args.animate] if args.animate else []):
        if os.path.isfile(stale) and not os.path.islink(stale):  # no product of an earlier run may pass for
            os.remove(stale)                                         # this one's (a link is written through)
    argv = [paths["trajectory"], "--scene", scene_path, "--log", paths["log"], "--plot", paths["execution"],
            "--report", paths["report"], "--kp", f"{args.kp[0]}/{args.kp[1]}",
            "--tolerance", str(args.tolerance), "--max-speed", repr(args.max_speed),
            "--max-start-offset", str(args.max_start_offset), "--seed", str(args.seed),
            "--latency" if args.latency else "--no-latency"]
    if args.time_scale is not None:
        argv += ["--time-scale", repr(args.time_scale)]
    if args.animate:
        argv += ["--animate", args.animate, "--frames", str(args.frames), "--dpi", str(args.dpi)]
    for b in args.brick:
        argv += ["--brick", b]
    code = execute.main(execute.build_parser().parse_args(argv))
    if os.path.isfile(paths["report"]) and code != EXIT_INPUT:
        with open(paths["report"], encoding="utf-8") as fh:
            sys.stdout.write("\n" + fh.read())
    return code
