"""Run a ``cplus.trajectory/1`` on NXT bricks and compare what they did with the plan.

The glue between :mod:`trajectory` (what to do, and kinematics to judge what was done) and
:mod:`nxt_link` (doing it):

1. ``load_trajectory`` validates the file (fields, and that its parts agree: times, steps,
   kinematics, setpoints); :func:`motor_limits` recomputes every motor's limits from the
   scene's joint limits and gear ratios (refusing a file whose kinematics or motors differ from
   the scene's), and :func:`streams_from_trajectory` turns each robot's ``setpoints_deg`` into an
   ``nxt_link.SetpointStream`` with those limits; anything unreachable or out of limits is
   refused before a brick is touched;
2. ``--brick NAME=PORT`` opens real devices (``/dev/rfcomm0``) or emulator ptys; without any
   ``--brick`` one emulated brick per robot is started in-process on a pty, and the run goes
   through the same serial path;
3. ``nxt_link.execute_streams`` checks that every motor stands at its first setpoint, uploads,
   starts all bricks together and reads the logs back (or, when a brick fails, stops the others
   and returns what was gathered in ``ExecutionFailed.log``);
4. :func:`tracking_report` reconstructs the executed end-effector and payload paths by forward
   kinematics (``RobotTrajectory.xy_from_motor_deg``) and measures the tracking error per
   robot (max and RMS, motor degrees and grid units); the payload is compared on a common
   clock, each robot's log shifted by when its brick actually started (measured from the log);
   ``--plot`` draws executed against planned (the paper's Fig. 5).

The command ``cplus execute`` is :mod:`cplus.cli.execute`.
"""
from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from dataclasses import dataclass, replace

import numpy as np

import nxt_link
import trajectory
from nxt_link.errors import SetpointError
from nxt_link.execlog import StartSkew, Stopped

__all__ = ["EmulatorSettings", "RobotTracking", "TrackingReport", "check_ports", "execute_trajectory",
           "motor_limits", "skew_verdict", "streams_from_trajectory", "tracking_report"]

#: Kinematics of the file and of the scene agree within this (grid units, degrees).
_KINEMATICS_TOL = 1e-6


def motor_limits(traj: trajectory.Trajectory, scene: trajectory.Scene | None = None
                 ) -> dict[str, tuple[tuple[int, int], ...]]:
    """Each robot's motor limits (degrees, in ``ports`` order), recomputed, not read.

    From the scene's joint limits and gear ratios when a scene is given (the file's kinematics
    and motors must then be the scene's), else from the file's own kinematics; the encoders
    count from the first sample's joint values. A file may narrow a motor's limits, never
    widen them.

    Raises:
        SetpointError: a robot of the file is not in the scene, or its kinematics or motors
            differ from the scene's.
    """
    out = {}
    for robot in traj.robots:
        arm = robot.arm
        ratios = {m.port: (m.joint, m.deg_per_unit, m.offset_deg) for m in robot.motors}
        if scene is not None:
            try:
                sr = scene.robot(robot.name)
            except KeyError:
                raise SetpointError(f"robot {robot.name!r} of the trajectory is not in the scene "
                                    f"{scene.file}") from None
            _same_kinematics(robot, sr.arm, scene.file)
            wanted = {m.port: (m.joint, m.deg_per_unit, m.offset_deg) for m in sr.motors}
            if wanted != ratios:
                raise SetpointError(
                    f"robot {robot.name}: the trajectory's motors {_motors_text(ratios)} are not "
                    f"the scene's {_motors_text(wanted)} ({scene.file})")
            arm = sr.arm
        limits = []
        for motor in robot.motors:
            if motor.joint == "s":
                lo, hi, zero = arm.s_limits[0], arm.s_limits[1], float(robot.s[0])
            else:
                lo, hi = (math.degrees(t) for t in arm.theta_limits_rad)
                zero = float(robot.theta_deg[0])
            ends = sorted(motor.offset_deg + motor.deg_per_unit * (v - zero) for v in (lo, hi))
            limits.append((max(motor.min_deg, math.ceil(ends[0] - 1e-9)),
                           min(motor.max_deg, math.floor(ends[1] + 1e-9))))
        out[robot.name] = tuple(limits)
    return out


def _same_kinematics(robot: trajectory.RobotTrajectory, arm: trajectory.Arm, where: str) -> None:
    mine = robot.arm
    pairs = (("rail_origin", mine.rail_origin, arm.rail_origin),
             ("rail_dir", mine.rail_dir, arm.rail_dir),
             ("arm_length", (mine.length,), (arm.length,)),
             ("s_limits", mine.s_limits, arm.s_limits),
             ("theta_limits_deg", tuple(math.degrees(t) for t in mine.theta_limits_rad),
              tuple(math.degrees(t) for t in arm.theta_limits_rad)))
    for name, a, b in pairs:
        if any(abs(x - y) > _KINEMATICS_TOL * max(1.0, abs(y)) for x, y in zip(a, b)):
            raise SetpointError(f"robot {robot.name}: the trajectory's {name} {_vec(a)} is not the "
                                f"scene's {_vec(b)} ({where})")


def _vec(values: tuple[float, ...]) -> str:
    return f"{values[0]:g}" if len(values) == 1 else "[" + ", ".join(f"{v:g}" for v in values) + "]"


def _motors_text(motors: Mapping[str, tuple[str, float, float]]) -> str:
    return ", ".join(f"{p}:{j}x{r:g}" + (f"{o:+g}" if o else "") for p, (j, r, o) in sorted(motors.items()))


def streams_from_trajectory(traj: trajectory.Trajectory, scene: trajectory.Scene | None = None,
                            *, origin: trajectory.Trajectory | None = None
                            ) -> list[nxt_link.SetpointStream]:
    """One setpoint stream per robot: its ports, the tick, its integer motor degrees.

    The motor limits are :func:`motor_limits` (from the scene when given); the brick program
    enforces them as well.

    A trajectory's setpoints count from its own first sample, where the encoders are zero when
    the brick program starts there. A trajectory that continues from elsewhere (a re-plan from
    where the arms stopped) runs on encoders that count from an earlier start: ``origin`` is
    the trajectory at whose first sample they read zero, and the setpoints and limits are
    recomputed from the samples in that frame (its robots must have the same motors).

    Raises:
        SetpointError: a robot's setpoints cannot be streamed (ports, limits, size), the file
            disagrees with the scene, or ``origin`` has other motors.
    """
    frame = origin or traj
    limits = motor_limits(frame, scene)
    streams = []
    for robot in traj.robots:
        rows_deg = np.asarray(robot.setpoints_deg)
        if origin is not None:
            try:
                base = origin.robot(robot.name)
            except KeyError:
                raise SetpointError(f"robot {robot.name!r} is not in the origin trajectory") from None
            if [(m.port, m.joint, m.deg_per_unit, m.offset_deg) for m in base.motors] != \
                    [(m.port, m.joint, m.deg_per_unit, m.offset_deg) for m in robot.motors]:
                raise SetpointError(f"robot {robot.name}: the origin trajectory has other motors")
            rows_deg = np.column_stack([
                np.rint(m.motor_deg(robot.s if m.joint == "s" else robot.theta_deg))
                for m in base.motors])
        rows = tuple(tuple(int(v) for v in row) for row in rows_deg)
        streams.append(nxt_link.SetpointStream(robot.name, robot.ports, int(traj.tick_ms), rows,
                                               limits[robot.name]))
    return streams


def check_ports(traj: trajectory.Trajectory, ports: Mapping[str, str]) -> None:
    """``ports`` (robot -> device) names every robot of ``traj`` once, each on its own device.

    Raises:
        SetpointError: an unknown robot, a robot without a port, or one port for two robots.
    """
    robots = [r.name for r in traj.robots]
    unknown = sorted(set(ports) - set(robots))
    if unknown:
        raise SetpointError(f"--brick {unknown[0]}: the trajectory has no robot "
                            f"{unknown[0]!r} (robots: {', '.join(robots)})")
    missing = [r for r in robots if r not in ports]
    if missing:
        raise SetpointError(f"no --brick for robot {missing[0]!r}: give one per robot, or "
                            "none to use emulated bricks")
    seen: dict[str, str] = {}
    for name, port in ports.items():
        key = _device_key(port)
        if key in seen:
            raise SetpointError(f"--brick {seen[key]} and --brick {name} are both {port}: each "
                                "robot needs its own brick")
        seen[key] = name


def _device_key(port: str) -> str:
    return os.path.realpath(port)


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
                       scene: trajectory.Scene | None = None,
                       ) -> nxt_link.ExecutionLog:
    """Execute ``traj`` on bricks at ``ports`` (robot name -> device), or on emulated bricks.

    With emulated bricks the options' ``time_scale`` is the emulator's.

    Raises:
        SetpointError: the trajectory cannot be executed (nothing moved).
        ExecutionFailed: a brick failed; ``.log`` holds what was gathered.
        LinkError: a port cannot be opened.
    """
    streams = streams_from_trajectory(traj, scene)
    robots = [r.name for r in traj.robots]
    if ports:
        check_ports(traj, ports)
    emu = emulator or EmulatorSettings()
    opts = options or nxt_link.ExecutionOptions()
    with ExitStack() as stack:
        if not ports:
            opts = replace(opts, time_scale=emu.time_scale)
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
        return nxt_link.execute_streams(streams, bricks, options=opts, on_progress=on_progress)


# ---------------------------------------------------------------------------- the comparison


@dataclass(frozen=True, slots=True)
class RobotTracking:
    """Tracking of one robot over its measured ticks: per motor in degrees, end-effector in
    grid units (empty tuples and NaN when nothing was measured)."""

    name: str
    ports: tuple[str, ...]
    max_deg: tuple[int, ...]
    rms_deg: tuple[float, ...]
    max_grid: float
    rms_grid: float
    ticks_measured: int = 0
    ticks: int = 0
    reached: str = "done"


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
    start_skew: StartSkew | None = None
    start_offsets_s: Mapping[str, float] | None = None
    stopped: Stopped | None = None

    @property
    def complete(self) -> bool:
        return self.stopped is None

    def text(self, header: str = "") -> str:
        mm = (lambda v: f"  ({v * self.unit_mm:.1f} mm)") if self.unit_mm else (lambda v: "")
        lines = [header] if header else []
        if self.stopped is not None:
            who = f" (brick {self.stopped.brick})" if self.stopped.brick and not \
                self.stopped.reason.startswith(f"brick {self.stopped.brick}") else ""
            lines.append(f"INCOMPLETE: the execution stopped at {self.stopped.t_s:.2f} s{who}: "
                         f"{self.stopped.reason}")
            for r in self.robots:
                lines.append(f"  {r.name}: {r.ticks_measured} of {r.ticks} ticks measured and read "
                             f"back (reached: {r.reached})")
        lines.append("tracking error (measured at the end of each tick - setpoint of that tick):")
        lines.append(f"  {'robot':<6} {'motor':<5} {'max deg':>8} {'rms deg':>8}")
        for r in self.robots:
            if not r.max_deg:
                lines.append(f"  {r.name:<6} (no measurements)")
            for port, mx, rms in zip(r.ports, r.max_deg, r.rms_deg):
                lines.append(f"  {r.name:<6} {port:<5} {mx:>8d} {rms:>8.2f}")
        lines.append("end-effector error (executed by forward kinematics - planned), grid units:")
        lines.append(f"  {'robot':<6} {'max':>8} {'rms':>8}")
        for r in self.robots:
            if r.max_deg:
                lines.append(f"  {r.name:<6} {r.max_grid:>8.3f} {r.rms_grid:>8.3f}{mm(r.max_grid)}")
        if self.payload is not None and self.payload_length_max_grid is not None:
            a, b = self.payload
            lines.append(f"payload {a}-{b} (on the common clock): length error max "
                         f"{self.payload_length_max_grid:.3f}, rms {self.payload_length_rms_grid:.3f}; "
                         f"midpoint error max {self.payload_mid_max_grid:.3f} grid units")
        if self.start_skew is not None:
            sk = self.start_skew
            order = ""
            if self.start_offsets_s:
                first = min(self.start_offsets_s, key=lambda n: self.start_offsets_s[n])  # type: ignore[index]
                last = max(self.start_offsets_s, key=lambda n: self.start_offsets_s[n])  # type: ignore[index]
                if first != last:
                    order = f"{last} after {first}, "
            lines.append(f"start skew (measured from the log): {sk.estimate * 1000:.0f} ms ({order}"
                         f"between {sk.min * 1000:.0f} and {sk.max * 1000:.0f} ms)")
        else:
            lines.append(f"bricks started within {self.start_skew_bound_s * 1000:.0f} ms of each "
                         "other (upper bound)")
        return "\n".join(lines) + "\n"


def _offsets_ticks(traj: trajectory.Trajectory, log: nxt_link.ExecutionLog) -> dict[str, float]:
    """When each brick started after the first one, in ticks (0 without a start interval)."""
    mids = {b.name: (b.start_s[0] + b.start_s[1]) / 2 for b in log.bricks if b.start_s is not None}
    if len(mids) < 2:
        return {r.name: 0.0 for r in traj.robots}
    first = min(mids.values())
    tick_s = traj.tick_ms / 1000.0
    return {r.name: (mids.get(r.name, first) - first) * log.time_scale / tick_s for r in traj.robots}


def _interp_rows(ticks: np.ndarray, rows: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Rows (one per known tick) at fractional tick indices ``at`` (clamped to the known range)."""
    return np.column_stack([np.interp(at, ticks, rows[:, j]) for j in range(rows.shape[1])])


def tracking_report(traj: trajectory.Trajectory, log: nxt_link.ExecutionLog,
                    unit_mm: float | None = None) -> TrackingReport:
    """Compare an execution log (complete or not) with the trajectory it executed.

    Per robot, on its own clock: the measured angle of tick k (taken when tick k ends) against
    the setpoint of tick k, and its end-effector position (forward kinematics) against the
    planned position of tick k, over the ticks measured. The payload is the segment between
    the first two robots' end-effectors (they hold its ends in the payload task); its length
    and midpoint are compared with the plan's on a common clock: each robot's log is shifted by
    how much later its brick started (measured from the log) and interpolated, so a late start
    shows as the payload error it causes.
    """
    robots = []
    executed: dict[str, np.ndarray] = {}
    common: dict[str, tuple[np.ndarray, np.ndarray]] = {}  # name -> (common ticks, xy)
    offsets = _offsets_ticks(traj, log)
    n = traj.ticks
    for robot in traj.robots:
        blog = log.brick(robot.name)
        known = np.array(blog.measured_ticks, dtype=int)
        if len(known) == 0:
            robots.append(RobotTracking(robot.name, tuple(blog.ports), (), (), math.nan, math.nan,
                                        0, n, blog.reached))
            executed[robot.name] = np.zeros((0, 2))
            continue
        measured = np.asarray([blog.measured_deg[k] for k in known], dtype=float)
        reference = np.asarray(blog.reference_deg, dtype=float)[known]
        err = np.abs(measured - reference)
        x, y = robot.xy_from_motor_deg(measured)
        dist = np.hypot(x - robot.x[known], y - robot.y[known])
        robots.append(RobotTracking(
            robot.name, tuple(blog.ports), tuple(int(v) for v in err.max(axis=0)),
            tuple(float(v) for v in np.sqrt((err ** 2).mean(axis=0))),
            float(dist.max()), float(math.sqrt(float((dist ** 2).mean()))),
            len(known), n, blog.reached))
        # on the common clock: at common tick j this brick was at its own (fractional) tick
        # j - offset; beyond its last known tick there is nothing to say
        last = min(n - 1, int(math.floor(known[-1] + offsets[robot.name] + 1e-9)))
        js = np.arange(last + 1)
        own = np.clip(js - offsets[robot.name], 0, n - 1)
        cx, cy = robot.xy_from_motor_deg(_interp_rows(known.astype(float), measured, own))
        common[robot.name] = (js, np.column_stack([cx, cy]))
        executed[robot.name] = common[robot.name][1]
    pair = None
    lmax = lrms = mid = None
    if len(traj.robots) >= 2:
        ra, rb = traj.robots[0], traj.robots[1]
        pair = (ra.name, rb.name)
        if ra.name in common and rb.name in common:
            m = min(len(common[ra.name][0]), len(common[rb.name][0]))
            if m:
                ea, eb = common[ra.name][1][:m], common[rb.name][1][:m]
                pa, pb = ra.path[:m], rb.path[:m]
                dl = np.abs(np.hypot(*(ea - eb).T) - np.hypot(*(pa - pb).T))
                lmax, lrms = float(dl.max()), float(math.sqrt(float((dl ** 2).mean())))
                mid = float(np.hypot(*(((ea + eb) - (pa + pb)) / 2).T).max())
    skew = log.start_skew()
    start_offsets = {name: off * traj.tick_ms / 1000.0 for name, off in offsets.items()} \
        if skew is not None else None
    return TrackingReport(tuple(robots), executed, pair, lmax, lrms, mid, log.start_skew_bound_s,
                          unit_mm, skew, start_offsets, log.stopped)


def skew_verdict(traj: trajectory.Trajectory, log: nxt_link.ExecutionLog
                 ) -> tuple[str | None, str | None]:
    """``(error, warning)`` about the bricks' start skew compared with one tick.

    An error when the bricks certainly started more than a tick apart (the lower bound
    measured from the log exceeds it), a warning when they probably did (the estimate does).
    """
    skew = log.start_skew()
    if skew is None:
        return None, None
    tick = traj.tick_ms / 1000.0
    text = (f"{skew.estimate * 1000:.0f} ms apart (between {skew.min * 1000:.0f} and "
            f"{skew.max * 1000:.0f} ms), more than one tick ({traj.tick_ms} ms)")
    if skew.min > tick:
        return f"the bricks started {text}", None
    if skew.estimate > tick:
        return None, f"the bricks probably started {text}"
    return None, None
