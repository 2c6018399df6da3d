"""``cplus run DOMAIN``: the whole robot job in one command.

Plan and refine (as ``cplus plan``), write the plan, its picture and its trajectory, execute
the trajectory on the bricks (emulated ones on pseudo-terminals when no ``--brick`` is given),
read the encoder logs back, report the tracking error and draw the execution.  Every product
goes to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import os
import sys

from cplus.cli import execute
from cplus.cli.common import EXIT_OK, OneLineArgumentParser, Warnings, horizon_progress, nonneg, query, robot_exit_code
from cplus.cli.plan import add_common

__all__ = ["build_parser", "main"]


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog="cplus run",
                              description="The whole robot job: plan, refine, trajectory, execute, plot.")
    p.add_argument("file", help="a robot task: a C+ domain with a scene.toml beside it (or --scene)")
    p.add_argument("--query", "-q", metavar="LABEL", default="0", help="the query to plan (default 0)")
    p.add_argument("--scene", metavar="FILE", help="scene file (default: scene.toml beside the domain)")
    p.add_argument("--brick", action="append", default=[], metavar="NAME=PORT",
                   help="a robot's brick port, e.g. r1=/dev/rfcomm0 (default: emulated bricks)")
    p.add_argument("--out", default="out", metavar="DIR",
                   help="where to write the plan, trajectory, execution log and pictures (default out/)")
    p.add_argument("--max-iterations", type=nonneg, default=0, metavar="N",
                   help="give up (exit 5) after N refinement iterations (default 0: no limit)")
    p.add_argument("--points-per-step", type=nonneg, default=10, metavar="K",
                   help="trajectory samples between two plan steps (default 10)")
    p.add_argument("--step-time", type=float, default=1.0, metavar="SECONDS",
                   help="duration of one plan step in the trajectory (default 1.0)")
    add_common(p)
    return p


def main(args: argparse.Namespace) -> int:
    from cplus.output import PLAN_FORMAT, Display, format_result
    from cplus.robot import RefineStatus, RobotTask, TaskError, export_plan, refine
    scene_path = args.scene or os.path.join(os.path.dirname(os.path.abspath(args.file)), "scene.toml")
    if not os.path.isfile(scene_path):
        raise TaskError(f"no scene: '{scene_path}' does not exist (give --scene FILE)")
    out = args.out
    os.makedirs(out, exist_ok=True)
    paths = {k: os.path.join(out, name) for k, name in (
        ("plan", "plan.txt"), ("json", "plan.json"), ("picture", "plan.png"), ("trajectory", "trajectory.json"),
        ("csv", "trajectory.csv"), ("log", "execution.json"), ("execution", "execution.png"),
        ("report", "report.txt"))}
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
    with open(paths["plan"], "w", encoding="utf-8") as fh:
        fh.write(text)
    with open(paths["json"], "w", encoding="utf-8") as fh:
        json.dump({"format": PLAN_FORMAT, "file": args.file, "results": [result.to_json(args.query)]}, fh,
                  indent=1)
    export_plan(task, result.states, None, domain_path=args.file, plot=paths["picture"],
                trajectory_json=paths["trajectory"], csv=paths["csv"], points_per_step=args.points_per_step,
                step_time=args.step_time, on_write=lambda path: print(f"% wrote {path}", file=sys.stderr))
    print(f"% executing {paths['trajectory']} on "
          + ("the bricks " + ", ".join(args.brick) if args.brick else "emulated bricks"), file=sys.stderr)
    argv = [paths["trajectory"], "--scene", scene_path, "--log", paths["log"], "--plot", paths["execution"],
            "--report", paths["report"]]
    for b in args.brick:
        argv += ["--brick", b]
    code = execute.main(execute.build_parser().parse_args(argv))
    if code == EXIT_OK and os.path.isfile(paths["report"]):
        with open(paths["report"], encoding="utf-8") as fh:
            sys.stdout.write("\n" + fh.read())
    return code
