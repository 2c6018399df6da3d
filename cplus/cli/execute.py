"""``cplus execute TRAJECTORY``: run a ``cplus.trajectory/1`` file on NXT bricks.

Without ``--brick`` each robot gets an emulated brick on a pseudo-terminal.  The tracking
report compares the encoder logs with the plan (:mod:`cplus.robot.execution`).

Exit codes: 0 done, 1 the link or a brick failed, 2 bad input, 130 interrupted.
"""
from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TextIO

import nxt_link
import trajectory
from cplus.cli.common import EXIT_INPUT, EXIT_INTERRUPTED, EXIT_LINK, EXIT_OK, OneLineArgumentParser, positive
from cplus.robot.execution import EmulatorSettings, execute_trajectory, tracking_report
from nxt_link.errors import LinkError, SetpointError

__all__ = ["build_parser", "main"]


class _ProgressPrinter:
    """Progress on stderr: one line per phase change, run progress every 25 %."""

    def __init__(self, out: TextIO) -> None:
        self.out = out
        self.last: dict[str, tuple[str, int]] = {}  # brick -> (phase, quarter or done)

    def __call__(self, p: nxt_link.Progress) -> None:
        phase, done, total = p.phase, p.done, max(1, p.total)
        counting = phase in ("run", "upload", "log")
        key = (phase, int(4 * done / total) if counting else done)
        if self.last.get(p.brick) == key:
            return
        if counting and done not in (0, total) and key[1] == 0:
            return
        self.last[p.brick] = key
        text = {
            "connect": "connecting" if done == 0 else "brick program answers",
            "upload": f"upload {done}/{p.total} rows",
            "homing": "going to the initial configuration" if done == 0 else "ready",
            "start": "started",
            "run": f"running {done}/{p.total} ticks",
            "log": f"log read back {done}/{p.total} rows",
            "done": "done",
        }.get(phase, phase)
        print(f"cplus execute: {p.brick}: {text}", file=self.out, flush=True)


def _kp(text: str) -> tuple[int, int]:
    num, _, den = text.partition("/")
    try:
        n, d = int(num), int(den or 1)
    except ValueError:
        raise argparse.ArgumentTypeError(f"gain must be N or N/D (integers), got {text!r}") \
            from None
    if not (1 <= n <= 255 and 1 <= d <= 255):
        raise argparse.ArgumentTypeError("gain numerator and denominator must be in 1..255")
    return n, d


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(
        prog="cplus execute",
        description="Execute a cplus.trajectory/1 file on NXT bricks (real, or emulated when no "
                    "--brick is given), report the tracking error and plot executed vs planned.")
    p.add_argument("trajectory", help="trajectory JSON (cplus.trajectory/1)")
    p.add_argument("--brick", action="append", default=[], metavar="NAME=PORT",
                   help="robot NAME's brick is at PORT (/dev/rfcomm0, or a `cplus brick` pty); "
                        "repeat per robot; none: emulate every brick")
    p.add_argument("--log", metavar="FILE", help="write the execution log (cplus.execlog/1)")
    p.add_argument("--plot", metavar="FILE", help="plot executed against planned (.png or .svg)")
    p.add_argument("--report", metavar="FILE",
                   help="write the tracking report to FILE instead of standard output")
    p.add_argument("--scene", metavar="SCENE",
                   help="scene file for the plot (default: scene.toml beside the trajectory's "
                        "source domain)")
    p.add_argument("--kp", type=_kp, default=(2, 1), metavar="N[/D]",
                   help="brick P-controller gain in %%power per degree (default 2)")
    p.add_argument("--tolerance", type=int, default=3, metavar="DEG",
                   help="initial configuration reached within DEG degrees (default 3)")
    p.add_argument("--max-speed", type=positive, default=1000.0, metavar="DEG_S",
                   help="refuse setpoints faster than this (default 1000 deg/s)")
    p.add_argument("--no-latency", action="store_true",
                   help="emulated bricks answer at once instead of with Bluetooth timing")
    p.add_argument("--time-scale", type=positive, default=1.0, metavar="X",
                   help="emulated bricks run X times faster than real time (default 1)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress on stderr")
    return p


def _scene_for(args: argparse.Namespace, traj: trajectory.Trajectory) -> trajectory.Scene | None:
    path = args.scene
    if path is None:
        domain = traj.source.get("domain") if isinstance(traj.source.get("domain"), str) else None
        candidates = []
        if domain:
            candidates.append(Path(domain).parent / "scene.toml")
            candidates.append(Path(args.trajectory).parent / Path(domain).parent / "scene.toml")
        path = next((str(c) for c in candidates if c.is_file()), None)
    if path is None:
        return None
    return trajectory.load_scene(path)


def main(args: argparse.Namespace) -> int:
    """``cplus execute``; returns the exit code."""
    err = sys.stderr
    ports: dict[str, str] = {}
    for item in args.brick:
        name, sep, port = item.partition("=")
        if not sep or not name or not port:
            print(f"cplus execute: error: --brick expects NAME=PORT, got {item!r}", file=err)
            return EXIT_INPUT
        if name in ports:
            print(f"cplus execute: error: two --brick options for {name!r}", file=err)
            return EXIT_INPUT
        ports[name] = port
    try:
        traj = trajectory.load_trajectory(args.trajectory)
        scene = _scene_for(args, traj) if (args.plot or args.scene) else None
        if args.plot and scene is None:
            print("cplus execute: error: --plot needs the scene: pass --scene SCENE", file=err)
            return EXIT_INPUT
        if scene is not None:
            missing = [r.name for r in traj.robots if r.name not in scene.robot_names]
            if missing:
                print(f"cplus execute: error: robot {missing[0]!r} of the trajectory is not in "
                      f"the scene {scene.file}", file=err)
                return EXIT_INPUT
    except trajectory.TrajectoryError as exc:
        print(f"cplus execute: {exc}", file=err)
        return EXIT_INPUT
    options = nxt_link.ExecutionOptions(
        controller=nxt_link.ControllerSettings(kp_num=args.kp[0], kp_den=args.kp[1],
                                               tolerance_deg=max(0, min(255, args.tolerance))),
        max_speed_deg_s=args.max_speed)
    progress = None if args.quiet else _ProgressPrinter(err)

    def announce(bricks: Mapping[str, str]) -> None:
        if not args.quiet:
            kind = "" if ports else " (emulated)"
            print("cplus execute: bricks " + ", ".join(f"{n}={p}" for n, p in bricks.items())
                  + kind, file=err, flush=True)

    try:
        log = execute_trajectory(traj, ports or None, options=options,
                                 emulator=EmulatorSettings(latency=not args.no_latency,
                                                           time_scale=args.time_scale),
                                 on_progress=progress, on_bricks=announce)
    except SetpointError as exc:
        print(f"cplus execute: refused before anything moved: {exc}", file=err)
        return EXIT_INPUT
    except LinkError as exc:
        print(f"cplus execute: {exc}", file=err)
        return EXIT_LINK
    except KeyboardInterrupt:
        print("cplus execute: interrupted (bricks told to stop)", file=err)
        return EXIT_INTERRUPTED
    unit_mm = scene.grid.unit_mm if scene is not None else None
    report = tracking_report(traj, log, unit_mm)
    header = (f"{args.trajectory}: {len(traj.robots)} robot(s), {traj.ticks} ticks x "
              f"{traj.tick_ms} ms ({traj.ticks * traj.tick_ms / 1000:g} s)")
    try:
        if args.log:
            _write(args.log, log.dumps() + "\n")
            if not args.quiet:
                print(f"cplus execute: wrote {args.log}", file=err)
        if args.plot:
            assert scene is not None
            _mkdir_for(args.plot)
            trajectory.plot_execution(scene, traj.planned_paths(), report.executed_paths,
                                      args.plot, title=f"{scene.name}: executed (solid) vs "
                                                       "planned (dashed)")
            if not args.quiet:
                print(f"cplus execute: wrote {args.plot}", file=err)
        if args.report:
            _write(args.report, report.text(header))
        else:
            sys.stdout.write(report.text(header))
    except trajectory.TrajectoryError as exc:
        print(f"cplus execute: {exc}", file=err)
        return EXIT_INPUT
    except OSError as exc:
        print(f"cplus execute: error: cannot write {exc.filename}: {exc.strerror}", file=err)
        return EXIT_INPUT
    return EXIT_OK


def _mkdir_for(path: str) -> None:
    parent = os.path.dirname(os.path.abspath(path))
    os.makedirs(parent, exist_ok=True)


def _write(path: str, text: str) -> None:
    _mkdir_for(path)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
