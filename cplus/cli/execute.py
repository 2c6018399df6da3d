"""``cplus execute TRAJECTORY``: run a ``cplus.trajectory/1`` file on NXT bricks.

Without ``--brick`` each robot gets an emulated brick on a pseudo-terminal.  The tracking
report compares the encoder logs with the plan (:mod:`cplus.robot.execution`).

Everything that can be checked is checked before a motor moves: every option, every output
path (``--log``, ``--report``, ``--plot``, ``--animate``), the trajectory file, the scene, the ``--brick``
ports.  A run that fails after the start still writes its log and report, marked incomplete
with the reason and the time it stopped.

Exit codes: 0 done, 1 the link or a brick failed (or the bricks started more than a tick
apart), 2 bad input, 130 SIGINT, 143 SIGTERM (the bricks stopped, the log and report written;
:mod:`cplus.cli.signals`), 124 a second signal.
"""
from __future__ import annotations

import argparse
import math
import sys
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

import numpy as np

import nxt_link
import trajectory
from cplus.cli.animation_options import FrameProgress, add_animation_options, animation_check
from cplus.cli.common import (
    EXIT_INPUT,
    EXIT_LINK,
    EXIT_OK,
    CliError,
    OneLineArgumentParser,
    distinct_bricks,
    nonempty,
    nonneg,
    parse_bricks,
    positive,
    time_scale,
)
from cplus.cli.paths import Input, Output, check_paths
from cplus.cli.signals import Shutdown, Stopped, exit_code_of, motors_off, reason_of
from cplus.files import output_path, write_output
from cplus.robot.execution import (
    EmulatorSettings,
    check_ports,
    execute_trajectory,
    skew_verdict,
    streams_from_trajectory,
    tracking_report,
)
from nxt_link.wire.errors import ExecutionFailed, ExecutionInterrupted, LinkError, SetpointError

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


def _degrees(lo: int, hi: int):
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected whole degrees, got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"must be in {lo}..{hi} degrees, got {v}")
        return v
    return parse


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(
        prog="cplus execute",
        description="Execute a cplus.trajectory/1 file on NXT bricks (real, or emulated when no "
                    "--brick is given), report the tracking error and plot executed vs planned.")
    p.add_argument("trajectory", help="trajectory JSON (cplus.trajectory/1)")
    add_execution_options(p)
    p.add_argument("--log", type=nonempty, metavar="FILE", help="write the execution log (cplus.execlog/1)")
    p.add_argument("--plot", type=nonempty, metavar="FILE", help="plot executed against planned (.png or .svg), with the "
                   "motor angles, tracking error and brick phases against time")
    add_animation_options(p)
    p.add_argument("--report", type=nonempty, metavar="FILE",
                   help="write the tracking report to FILE instead of standard output")
    p.add_argument("--scene", type=nonempty, metavar="SCENE",
                   help="the scene: motor limits and the plot (default: scene.toml beside the "
                        "trajectory's source domain)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress on stderr")
    return p


def add_execution_options(p: argparse.ArgumentParser, *, fast: bool = False) -> None:
    """The options ``cplus execute`` and ``cplus run`` share.  ``fast``: emulated bricks run
    10 times faster than real time with instant answers unless asked otherwise."""
    p.add_argument("--brick", action="append", default=[], metavar="NAME=PORT",
                   help="robot NAME's brick is at PORT (/dev/rfcomm0, or a `cplus brick` pty); "
                        "repeat per robot; none: emulate every brick")
    p.add_argument("--kp", type=_kp, default=(2, 1), metavar="N[/D]",
                   help="brick P-controller gain in %%power per degree (default 2)")
    p.add_argument("--tolerance", type=_degrees(0, 255), default=3, metavar="DEG",
                   help="initial configuration reached within DEG degrees (0..255, default 3)")
    p.add_argument("--max-speed", type=positive, default=1000.0, metavar="DEG_S",
                   help="refuse setpoints faster than this (default 1000 deg/s)")
    p.add_argument("--max-start-offset", type=_degrees(0, 32767), default=10, metavar="DEG",
                   help="refuse to start when a motor stands more than DEG degrees from its first "
                        "setpoint (default 10)")
    latency = p.add_mutually_exclusive_group()
    latency.add_argument("--latency", dest="latency", action="store_true", default=not fast,
                         help="emulated bricks answer with Bluetooth timing"
                              + ("" if fast else " (default)"))
    latency.add_argument("--no-latency", dest="latency", action="store_false",
                         help="emulated bricks answer at once" + (" (default)" if fast else ""))
    p.add_argument("--time-scale", type=time_scale, default=None, metavar="X",
                   help="emulated bricks run on the wall clock, X times faster than real time (1 = real "
                        "time); default: on simulated time, as fast as the emulation goes and whatever the "
                        "machine's load; with --brick, the bricks' own time scale (default 1)")
    p.add_argument("--seed", type=nonneg, default=0, metavar="N",
                   help="emulated bricks: the random seed of the link model and the session ids (default 0; "
                        "on simulated time the same seed gives the same log)")


def run_timeline(log: nxt_link.ExecutionLog, clock: str = "PC clock") -> trajectory.RunTimeline:
    """The log as `trajectory` draws it over time: each brick's setpoints and readings per tick
    on the log's clock (a tick lasts ``tick_ms / time_scale`` there), its start interval, its
    events, and the run's stop and start skew. ``clock`` names that clock on the time axes: the
    PC's, or the simulated clock of emulated bricks on simulated time (:func:`clock_of`)."""
    bricks = []
    for b in log.bricks:
        measured = np.array([[math.nan] * len(b.ports) if r is None else r for r in b.measured_deg], dtype=float)
        bricks.append(trajectory.BrickTimeline(
            b.name, b.ports, b.tick_ms / 1000.0 / log.time_scale, np.array(b.reference_deg, dtype=float), measured,
            start_s=b.start_s, events=tuple((e.t_s, e.event, e.detail) for e in b.events), reached=b.reached))
    skew = log.start_skew()
    return trajectory.RunTimeline(tuple(bricks), None if log.stopped is None else (log.stopped.t_s, log.stopped.reason),
                                  None if skew is None else (skew.estimate, skew.min, skew.max), clock)


def clock_of(args: argparse.Namespace) -> str:
    """The clock an execution's times are on: emulated bricks (no ``--brick``) without
    ``--time-scale`` run on simulated time, every other run on the PC's clock."""
    return "simulated clock" if not args.brick and args.time_scale is None else "PC clock"


def execution_options(args: argparse.Namespace) -> nxt_link.ExecutionOptions:
    return nxt_link.ExecutionOptions(
        controller=nxt_link.ControllerSettings(kp_num=args.kp[0], kp_den=args.kp[1],
                                               tolerance_deg=args.tolerance),
        max_speed_deg_s=args.max_speed, max_start_offset_deg=args.max_start_offset,
        time_scale=args.time_scale or 1.0)


def _scene_path(args: argparse.Namespace, traj: trajectory.Trajectory) -> str | None:
    """``--scene``, else the scene the trajectory names (``source.scene``, relative to the
    trajectory file), else ``scene.toml`` beside its ``source.domain`` (relative to the
    trajectory file; in a file written before the scene was named, relative to where its run
    started, as it was then).  A named scene that is missing is not replaced by another."""
    from trajectory.export import referenced_paths
    path = args.scene
    if path is None:
        scene, domain = (traj.source.get(k) if isinstance(traj.source.get(k), str) else None
                         for k in ("scene", "domain"))
        if scene:
            candidates = referenced_paths(scene, args.trajectory)
        elif domain:
            candidates = [p.parent / "scene.toml"
                          for p in referenced_paths(domain, args.trajectory, written_before=True)]
        else:
            candidates = []
        path = next((str(c) for c in candidates if c.is_file()), None)
    return path


@dataclass
class _Outputs:
    """Where the products go, and how to write them whatever happened."""

    args: argparse.Namespace
    traj: trajectory.Trajectory
    scene: trajectory.Scene | None
    err: TextIO
    lock: threading.Lock = field(default_factory=threading.Lock)  # the watchdog may write too

    def write(self, log: nxt_link.ExecutionLog, plot: bool = True) -> bool:
        """Log, report, plot and animation, in that order (the pictures are the slow ones: a run
        stopped by a signal, ``plot=False``, leaves them out so that the stop stays within its
        2 s); returns False (after one line on stderr) if one failed."""
        with self.lock:
            return self._write_all(log, plot)

    def _write_all(self, log: nxt_link.ExecutionLog, plot: bool) -> bool:
        args = self.args
        unit_mm = self.scene.grid.unit_mm if self.scene is not None else None
        report = tracking_report(self.traj, log, unit_mm)
        header = (f"{args.trajectory}: {len(self.traj.robots)} robot(s), {self.traj.ticks} ticks "
                  f"x {self.traj.tick_ms} ms ({self.traj.ticks * self.traj.tick_ms / 1000:g} s)")
        writing = "standard output"
        try:
            if args.log:
                writing = f"--log {args.log}"
                write_output(args.log, log.dumps() + "\n")
                self._wrote(args.log)
            if args.report:
                writing = f"--report {args.report}"
                write_output(args.report, report.text(header))
                self._wrote(args.report)
            else:
                writing = "standard output"
                sys.stdout.write(report.text(header))
                sys.stdout.flush()
            if args.plot and self.scene is not None and not plot:
                print(f"cplus execute: no plot {args.plot}: the run was stopped by a signal", file=self.err)
            elif args.plot and self.scene is not None:
                writing = f"--plot {args.plot}"
                title = f"{self.scene.name}: executed (solid) vs planned (dashed)"
                if not log.complete:
                    title += ", incomplete"
                with output_path(args.plot) as tmp:
                    trajectory.plot_execution(self.scene, self.traj.planned_paths(),
                                              {k: v for k, v in report.executed_paths.items() if len(v)},
                                              tmp, title=title, timeline=run_timeline(log, clock_of(args)))
                self._wrote(args.plot)
            if args.animate and self.scene is not None and not plot:
                print(f"cplus execute: no animation {args.animate}: the run was stopped by a signal", file=self.err)
            elif args.animate and self.scene is not None:
                writing = f"--animate {args.animate}"
                title = f"{self.scene.name}: executed (solid) vs planned (dashed)"
                with output_path(args.animate) as tmp:
                    trajectory.animate_run(self.scene, self.traj, tmp, timeline=run_timeline(log, clock_of(args)),
                                           title=title + ("" if log.complete else ", incomplete"),
                                           max_frames=args.frames, dpi=args.dpi,
                                           on_progress=FrameProgress("cplus execute", args.animate, self.err,
                                                                     args.quiet))
                self._wrote(args.animate)
        except trajectory.TrajectoryError as exc:
            print(f"cplus execute: error: {exc}", file=self.err)
            return False
        except OSError as exc:
            print(f"cplus execute: error: cannot write {writing}: {exc.strerror or exc}", file=self.err)
            return False
        return True

    def _wrote(self, path: str) -> None:
        if not self.args.quiet:
            print(f"cplus execute: wrote {path}", file=self.err)


class _ForcedLog:
    """The shutdown watchdog's log: while the bricks run, a stop that misses its deadline (a
    link stuck reconnecting) still writes the log gathered so far, marked stopped and forced,
    instead of losing it. Armed by the execution, disarmed once it returns or raises (the
    orderly path writes the log itself)."""

    def __init__(self, outputs: _Outputs, shutdown: Shutdown) -> None:
        self.outputs = outputs
        self.shutdown = shutdown
        self.snapshot: Callable[[str], nxt_link.ExecutionLog] | None = None

    def arm(self, snapshot: Callable[[str], nxt_link.ExecutionLog]) -> None:
        self.snapshot = snapshot

    def __call__(self) -> None:
        snapshot = self.snapshot
        if snapshot is None:
            return
        signum = self.shutdown.signum
        reason = str(Stopped(signum)) if signum is not None else "interrupted"
        self.outputs.write(snapshot(f"{reason}, forced after {self.shutdown.grace_s:g} s (motors commanded off)"),
                           plot=False)


def main(args: argparse.Namespace) -> int:
    """``cplus execute``; returns the exit code."""
    err = sys.stderr
    prog = "cplus execute"
    try:
        ports = distinct_bricks(parse_bricks(args.brick, prog), prog)
    except CliError as exc:
        print(exc, file=err)
        return EXIT_INPUT
    products = [Output("--log", args.log), Output("--report", args.report), Output("--plot", args.plot),
                Output("--animate", args.animate)]
    problem = None
    if args.plot and Path(args.plot).suffix.lower() not in (".png", ".svg"):
        problem = f"{prog}: error: --plot {args.plot}: use a .png or .svg file name"
    if problem is None:
        problem = animation_check(args.animate, "--animate", prog)
    try:
        if problem is not None:
            raise CliError(problem)
        check_paths(prog, [Input(args.trajectory, "the trajectory"), Input(args.scene, "the scene")], products)
        traj = trajectory.load_trajectory(args.trajectory)
        scene_path = _scene_path(args, traj)
        check_paths(prog, [Input(args.trajectory, "the trajectory"), Input(scene_path, "the scene")], products)
        scene = None if scene_path is None else trajectory.load_scene(scene_path)
    except CliError as exc:
        print(exc, file=err)
        return EXIT_INPUT
    except trajectory.TrajectoryError as exc:
        print(f"{prog}: error: {exc}", file=err)
        return EXIT_INPUT
    for option, given in (("--plot", args.plot), ("--animate", args.animate)):
        if given and scene is None:
            print(f"{prog}: error: {option} needs the scene: pass --scene SCENE", file=err)
            return EXIT_INPUT
    if scene is None:
        print(f"{prog}: warning: no scene found beside the trajectory's domain (give --scene): "
              "the motor limits come from the trajectory file's own joint limits", file=err)
    try:
        streams_from_trajectory(traj, scene)
        if ports:
            check_ports(traj, ports)
    except SetpointError as exc:
        print(f"{prog}: error: refused before anything moved: {exc}", file=err)
        return EXIT_INPUT
    progress = None if args.quiet else _ProgressPrinter(err)
    outputs = _Outputs(args, traj, scene, err)

    def announce(bricks: Mapping[str, str]) -> None:
        if not args.quiet:
            kind = "" if ports else " (emulated)"
            print(f"{prog}: bricks " + ", ".join(f"{n}={p}" for n, p in bricks.items())
                  + kind, file=err, flush=True)

    with Shutdown(prog) as shutdown:
        opened: list = []
        forced_log = _ForcedLog(outputs, shutdown)
        shutdown.on_force(lambda: motors_off(opened))
        shutdown.on_force(forced_log)

        def execute() -> nxt_link.ExecutionLog:
            try:
                return execute_trajectory(traj, ports or None, options=execution_options(args),
                                          emulator=EmulatorSettings(latency=args.latency,
                                                                    time_scale=args.time_scale, seed=args.seed),
                                          on_progress=progress, on_bricks=announce, scene=scene,
                                          on_connected=lambda bricks: opened.extend(bricks.values()),
                                          on_snapshot=forced_log.arm)
            finally:
                forced_log.snapshot = None    # what happens next writes the log itself
        try:
            log = execute()
        except SetpointError as exc:
            print(f"{prog}: error: refused before anything moved: {exc}", file=err)
            return EXIT_INPUT
        except ExecutionFailed as exc:
            outputs.write(exc.log)  # type: ignore[arg-type]
            print(f"{prog}: {exc}", file=err)
            return EXIT_LINK
        except ExecutionInterrupted as exc:
            outputs.write(exc.log, plot=shutdown.signum is None)  # type: ignore[arg-type]
            stopped = getattr(exc.log, "stopped", None)
            print(f"{prog}: {stopped.reason if stopped is not None else 'interrupted'} (bricks told to stop)",
                  file=err)
            return shutdown.exit_code
        except (LinkError, nxt_link.SimulationStalled) as exc:
            print(f"{prog}: {exc}", file=err)
            return EXIT_LINK
        except KeyboardInterrupt as exc:
            print(f"{prog}: {reason_of(exc)} (bricks told to stop)", file=err)
            return exit_code_of(exc)
    if not outputs.write(log):
        return EXIT_INPUT
    error, warning = skew_verdict(traj, log)
    if warning:
        print(f"{prog}: warning: {warning}", file=err)
    if error:
        print(f"{prog}: {error}", file=err)
        return EXIT_LINK
    return EXIT_OK
