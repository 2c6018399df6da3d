"""``cplus execute``: run a ``cplus.trajectory/1`` file on NXT bricks and compare with the plan.

The glue between :mod:`trajectory` (what to do, and kinematics to judge what was done) and
:mod:`nxt_link` (doing it):

1. ``load_trajectory`` validates the file; :func:`streams_from_trajectory` turns each robot's
   ``setpoints_deg`` into an ``nxt_link.SetpointStream`` (ports, tick, joint limits as motor
   limits); anything unreachable or out of limits is refused before a brick is touched;
2. ``--brick NAME=PORT`` opens real devices (``/dev/rfcomm0``) or emulator ptys; without any
   ``--brick`` one emulated brick per robot is started in-process on a pty, and the run goes
   through the same serial path;
3. ``nxt_link.execute_streams`` uploads, starts all bricks together and reads the logs back;
4. :func:`tracking_report` reconstructs the executed end-effector and payload paths by forward
   kinematics (``RobotTrajectory.xy_from_motor_deg``) and measures the tracking error per
   robot (max and RMS, motor degrees and grid units); ``--plot`` draws executed against
   planned (the paper's Fig. 5) with ``trajectory.plot_execution``.

Exit codes: 0 done, 1 the link or a brick failed, 2 bad input, 130 interrupted.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence, TextIO

import numpy as np

import nxt_link
import trajectory
from nxt_link.cli import CliError, OneLineArgumentParser
from nxt_link.errors import LinkError, SetpointError

__all__ = ["execute_main", "streams_from_trajectory", "execute_trajectory", "tracking_report",
           "TrackingReport", "RobotTracking", "EmulatorSettings"]

EXIT_OK, EXIT_LINK, EXIT_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


def streams_from_trajectory(traj: trajectory.Trajectory) -> list[nxt_link.SetpointStream]:
    """One setpoint stream per robot: its ports, the tick, its integer motor degrees.

    The joint limits (mapped to motor degrees in the file) become the motor limits the brick
    program enforces as well.

    Raises:
        SetpointError: a robot's setpoints cannot be streamed (ports, limits, size).
    """
    streams = []
    for robot in traj.robots:
        rows = tuple(tuple(int(v) for v in row) for row in np.asarray(robot.setpoints_deg))
        limits = tuple((int(m.min_deg), int(m.max_deg)) for m in robot.motors)
        streams.append(nxt_link.SetpointStream(robot.name, robot.ports, int(traj.tick_ms), rows,
                                               limits))
    return streams


@dataclass(frozen=True, slots=True)
class EmulatorSettings:
    """How to emulate the bricks when no port is given."""

    latency: bool = True
    time_scale: float = 1.0


def execute_trajectory(traj: trajectory.Trajectory, ports: Mapping[str, str] | None = None, *,
                       options: nxt_link.ExecutionOptions | None = None,
                       emulator: EmulatorSettings | None = None,
                       on_progress: Callable[[nxt_link.Progress], None] | None = None,
                       on_bricks: Callable[[Mapping[str, str]], None] | None = None,
                       ) -> nxt_link.ExecutionLog:
    """Execute ``traj`` on bricks at ``ports`` (robot name -> device), or on emulated bricks.

    Raises:
        SetpointError: the trajectory cannot be executed (nothing moved).
        LinkError: a port cannot be opened, a brick fails or does not answer.
    """
    streams = streams_from_trajectory(traj)
    robots = [r.name for r in traj.robots]
    if ports:
        unknown = sorted(set(ports) - set(robots))
        if unknown:
            raise SetpointError(f"--brick {unknown[0]}: the trajectory has no robot "
                                f"{unknown[0]!r} (robots: {', '.join(robots)})")
        missing = [r for r in robots if r not in ports]
        if missing:
            raise SetpointError(f"no --brick for robot {missing[0]!r}: give one per robot, or "
                                "none to use emulated bricks")
    emu = emulator or EmulatorSettings()
    with ExitStack() as stack:
        if not ports:
            servers = {}
            for name in robots:
                config = nxt_link.EmulatorConfig(
                    name=name,
                    link=nxt_link.LinkParams() if emu.latency else nxt_link.LinkParams.instant(),
                    stale_frame_ms=250.0 * emu.time_scale)
                server = nxt_link.PtyBrickServer(nxt_link.BrickEmulator(config),
                                                 time_scale=emu.time_scale)
                server.start()
                stack.callback(server.stop)
                servers[name] = server.path
            ports = servers
        if on_bricks is not None:
            on_bricks(ports)
        bricks = {}
        for name in robots:
            transport = nxt_link.SerialTransport(ports[name])
            stack.callback(transport.close)
            bricks[name] = nxt_link.Brick(transport, name=name)
        return nxt_link.execute_streams(streams, bricks, options=options, on_progress=on_progress)


# ---------------------------------------------------------------------------- the comparison


@dataclass(frozen=True, slots=True)
class RobotTracking:
    """Tracking of one robot: per motor in degrees, end-effector in grid units."""

    name: str
    ports: tuple[str, ...]
    max_deg: tuple[int, ...]
    rms_deg: tuple[float, ...]
    max_grid: float
    rms_grid: float


@dataclass(frozen=True, slots=True)
class TrackingReport:
    robots: tuple[RobotTracking, ...]
    executed_paths: Mapping[str, np.ndarray]
    payload: tuple[str, str] | None
    payload_length_max_grid: float | None
    payload_length_rms_grid: float | None
    payload_mid_max_grid: float | None
    start_skew_bound_s: float
    unit_mm: float | None = None

    def text(self, header: str = "") -> str:
        mm = (lambda v: f"  ({v * self.unit_mm:.1f} mm)") if self.unit_mm else (lambda v: "")
        lines = [header] if header else []
        lines.append("tracking error (measured at the end of each tick - setpoint of that tick):")
        lines.append(f"  {'robot':<6} {'motor':<5} {'max deg':>8} {'rms deg':>8}")
        for r in self.robots:
            for port, mx, rms in zip(r.ports, r.max_deg, r.rms_deg):
                lines.append(f"  {r.name:<6} {port:<5} {mx:>8d} {rms:>8.2f}")
        lines.append("end-effector error (executed by forward kinematics - planned), grid units:")
        lines.append(f"  {'robot':<6} {'max':>8} {'rms':>8}")
        for r in self.robots:
            lines.append(f"  {r.name:<6} {r.max_grid:>8.3f} {r.rms_grid:>8.3f}{mm(r.max_grid)}")
        if self.payload is not None:
            a, b = self.payload
            lines.append(f"payload {a}-{b}: length error max {self.payload_length_max_grid:.3f}, "
                         f"rms {self.payload_length_rms_grid:.3f}; midpoint error max "
                         f"{self.payload_mid_max_grid:.3f} grid units")
        lines.append(f"bricks started within {self.start_skew_bound_s * 1000:.0f} ms of each "
                     "other (upper bound)")
        return "\n".join(lines) + "\n"


def tracking_report(traj: trajectory.Trajectory, log: nxt_link.ExecutionLog,
                    unit_mm: float | None = None) -> TrackingReport:
    """Compare an execution log with the trajectory it executed.

    The measured angle of tick k (taken when tick k ends) is compared with the setpoint of
    tick k, and its end-effector position (forward kinematics) with the planned position of
    tick k. The payload is the segment between the first two robots' end-effectors (they hold
    its ends in the payload task): its length and midpoint are compared with the plan's.
    """
    robots = []
    executed: dict[str, np.ndarray] = {}
    planned: dict[str, np.ndarray] = {}
    for robot in traj.robots:
        blog = log.brick(robot.name)
        measured = np.asarray(blog.measured_deg, dtype=float)
        reference = np.asarray(blog.reference_deg, dtype=float)
        err = np.abs(measured - reference)
        x, y = robot.xy_from_motor_deg(measured)
        path = np.column_stack([x, y])
        executed[robot.name] = path
        planned[robot.name] = robot.path
        dist = np.hypot(*(path - robot.path).T)
        robots.append(RobotTracking(
            robot.name, tuple(blog.ports), tuple(int(v) for v in err.max(axis=0)),
            tuple(float(v) for v in np.sqrt((err ** 2).mean(axis=0))),
            float(dist.max()), float(math.sqrt(float((dist ** 2).mean())))))
    pair = None
    lmax = lrms = mid = None
    if len(traj.robots) >= 2:
        a, b = traj.robots[0].name, traj.robots[1].name
        pair = (a, b)
        le = np.hypot(*(executed[a] - executed[b]).T)
        lp = np.hypot(*(planned[a] - planned[b]).T)
        dl = np.abs(le - lp)
        lmax, lrms = float(dl.max()), float(math.sqrt(float((dl ** 2).mean())))
        mid = float(np.hypot(*(((executed[a] + executed[b]) - (planned[a] + planned[b])) / 2).T)
                    .max())
    return TrackingReport(tuple(robots), executed, pair, lmax, lrms, mid,
                          log.start_skew_bound_s, unit_mm)


# ---------------------------------------------------------------------------- the command


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


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not v > 0:
        raise argparse.ArgumentTypeError("must be > 0")
    return v


def _parser() -> OneLineArgumentParser:
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
    p.add_argument("--max-speed", type=_positive, default=1000.0, metavar="DEG_S",
                   help="refuse setpoints faster than this (default 1000 deg/s)")
    p.add_argument("--no-latency", action="store_true",
                   help="emulated bricks answer at once instead of with Bluetooth timing")
    p.add_argument("--time-scale", type=_positive, default=1.0, metavar="X",
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


def execute_main(argv: Sequence[str]) -> int:
    """Entry point of ``cplus execute``; returns the exit code."""
    err = sys.stderr
    try:
        args = _parser().parse_args(list(argv))
    except CliError as exc:
        print(exc, file=err)
        return EXIT_INPUT
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
