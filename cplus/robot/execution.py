"""Run a ``cplus.trajectory/1`` on NXT bricks and compare what they did with the plan.

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

The command ``cplus execute`` is :mod:`cplus.cli.execute`.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from dataclasses import dataclass

import numpy as np

import nxt_link
import trajectory
from nxt_link.errors import SetpointError

__all__ = ["EmulatorSettings", "RobotTracking", "TrackingReport", "execute_trajectory", "streams_from_trajectory",
           "tracking_report"]


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
            transport = nxt_link.SerialTransport(ports[name])  # type: ignore[operator]
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
